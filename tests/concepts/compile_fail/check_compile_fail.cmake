# Runs the compiler on SOURCE twice: with CONTROL_DEFINITION the file must compile; without
# it the compile must fail and the diagnostic must contain EXPECTED. Invoked with
#   cmake -DCOMPILER=... -DSTD_FLAG=... -DINCLUDE_DIRS=a|b -DSOURCE=... -DEXPECTED=...
#         -DCONTROL_DEFINITION=... [-DIMPLICIT_DIRS=a|b] -P check_compile_fail.cmake
# Include directories the compiler searches anyway (IMPLICIT_DIRS) are not passed again.
foreach(var COMPILER STD_FLAG INCLUDE_DIRS SOURCE EXPECTED CONTROL_DEFINITION)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "check_compile_fail.cmake: ${var} is not set")
  endif()
endforeach()

string(REPLACE "|" ";" include_dirs "${INCLUDE_DIRS}")
string(REPLACE "|" ";" implicit_dirs "${IMPLICIT_DIRS}")
if(implicit_dirs)
  list(REMOVE_ITEM include_dirs ${implicit_dirs})
endif()
set(flags ${STD_FLAG} -fsyntax-only)
foreach(dir ${include_dirs})
  list(APPEND flags "-I${dir}")
endforeach()

execute_process(
  COMMAND ${COMPILER} ${flags} -D${CONTROL_DEFINITION} ${SOURCE}
  RESULT_VARIABLE control_result
  OUTPUT_VARIABLE control_output
  ERROR_VARIABLE control_output)
if(NOT control_result EQUAL 0)
  message(FATAL_ERROR "the control build (-D${CONTROL_DEFINITION}) of ${SOURCE} must compile but "
                      "failed:\n${control_output}")
endif()

execute_process(
  COMMAND ${COMPILER} ${flags} ${SOURCE}
  RESULT_VARIABLE result
  OUTPUT_VARIABLE output
  ERROR_VARIABLE output)
if(result EQUAL 0)
  message(FATAL_ERROR "${SOURCE} compiled, but it must be rejected")
endif()
string(FIND "${output}" "${EXPECTED}" position)
if(position EQUAL -1)
  message(FATAL_ERROR "${SOURCE} was rejected, but the diagnostic does not mention "
                      "'${EXPECTED}':\n${output}")
endif()
message(STATUS "${SOURCE} was rejected with a diagnostic naming '${EXPECTED}'")
