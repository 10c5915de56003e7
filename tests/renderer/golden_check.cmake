# One golden image test (tests/renderer/golden/): renders with RENDER (segpath-render) and ARGS
# (separated by |) into OUT, then compares OUT with GOLDEN using COMPARE (pfm_compare), which
# must accept it. With EXPECT_DIFFERENT=ON the comparison must reject it instead (exit code 1,
# not an unreadable file or a crash): the check that the golden tests can fail.
string(REPLACE "|" ";" ARGS "${ARGS}")
file(REMOVE ${OUT})
execute_process(COMMAND ${RENDER} ${ARGS} --out ${OUT} RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT code STREQUAL "0")
  string(REPLACE ";" " " shown "${ARGS}")
  message(FATAL_ERROR "segpath-render ${shown} failed (${code}): ${out}${err}")
endif()
message(STATUS "${out}")
execute_process(COMMAND ${COMPARE} ${GOLDEN} ${OUT} RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(EXPECT_DIFFERENT)
  if(NOT code STREQUAL "1")
    message(FATAL_ERROR "expected pfm_compare to reject ${OUT} (exit code 1), got '${code}': ${out}${err}")
  endif()
  message(STATUS "rejected as expected: ${out}")
elseif(NOT code STREQUAL "0")
  message(FATAL_ERROR "${OUT} does not match the golden image (pfm_compare exit code '${code}'): ${out}${err} "
                      "If the change is deliberate, re-record with scripts/record-golden.sh.")
else()
  message(STATUS "${out}")
endif()
