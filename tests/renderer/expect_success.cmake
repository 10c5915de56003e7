# Runs BINARY with ARGS (arguments separated by |) and checks that it succeeds (exit code 0) with
# stderr matching every regular expression of ERR (separated by |, each a whole expression
# without alternation) and stdout matching OUT.
string(REPLACE "|" ";" ARGS "${ARGS}")
execute_process(COMMAND ${BINARY} ${ARGS} RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT code STREQUAL "0")
  message(FATAL_ERROR "expected exit code 0 for '${ARGS}', got '${code}'; stderr: ${err}")
endif()
string(REPLACE "|" ";" ERR "${ERR}")
foreach(expression IN LISTS ERR)
  if(NOT err MATCHES "${expression}")
    message(FATAL_ERROR "expected stderr of '${ARGS}' to match '${expression}', got: ${err}")
  endif()
endforeach()
if(DEFINED OUT AND NOT out MATCHES "${OUT}")
  message(FATAL_ERROR "expected stdout of '${ARGS}' to match '${OUT}', got: ${out}")
endif()
message(STATUS "'${ARGS}': ${err}${out}")
