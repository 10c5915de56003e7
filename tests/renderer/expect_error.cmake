# Runs BINARY with ARGS (arguments separated by |) and checks that it rejects them cleanly: exit code 1 or 2
# (a crash gives a signal name instead), and exactly one line on stderr starting with
# "segpath-render:"; with MESSAGE, that line must also match the regular expression MESSAGE.
string(REPLACE "|" ";" ARGS "${ARGS}")
execute_process(COMMAND ${BINARY} ${ARGS} RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT (code STREQUAL "1" OR code STREQUAL "2"))
  message(FATAL_ERROR "expected exit code 1 or 2 for '${ARGS}', got '${code}'; stderr: ${err}")
endif()
string(REGEX MATCHALL "\n" newlines "${err}")
list(LENGTH newlines lines)
if(NOT lines EQUAL 1 OR NOT err MATCHES "^segpath-render: ")
  message(FATAL_ERROR "expected one line 'segpath-render: ...' on stderr for '${ARGS}', got: ${err}")
endif()
if(DEFINED MESSAGE AND NOT err MATCHES "${MESSAGE}")
  message(FATAL_ERROR "expected the error for '${ARGS}' to match '${MESSAGE}', got: ${err}")
endif()
message(STATUS "rejected '${ARGS}': ${err}")
