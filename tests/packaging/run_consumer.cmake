# Driver of one packaging test, run with `cmake -P`. MODE=find_package: configure a fresh
# segpath (tests, examples, benchmarks off), install it, move the prefix (proving the
# package is relocatable) and build a consumer against it through CMAKE_PREFIX_PATH.
# MODE=subdirectory: build a consumer that add_subdirectory()s the segpath source tree.
# Either way the consumer's own CTest test (running its program) must pass.
cmake_minimum_required(VERSION 3.21)

foreach(var MODE SEGPATH_SOURCE_DIR CONSUMER_DIR WORK_DIR GENERATOR CXX_COMPILER)
  if(NOT DEFINED ${var} OR "${${var}}" STREQUAL "")
    message(FATAL_ERROR "run_consumer.cmake: -D${var}=... is required")
  endif()
endforeach()

# Runs a command, echoing it first; any failure ends the test.
function(run step)
  string(REPLACE ";" " " shown "${ARGN}")
  message(STATUS "[${MODE}] ${step}: ${shown}")
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE result)
  if(NOT result EQUAL 0)
    message(FATAL_ERROR "[${MODE}] ${step} failed (${result})")
  endif()
endfunction()

set(common_args -G "${GENERATOR}" "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}")
if(MAKE_PROGRAM)
  list(APPEND common_args "-DCMAKE_MAKE_PROGRAM=${MAKE_PROGRAM}")
endif()
if(BUILD_TYPE)
  list(APPEND common_args "-DCMAKE_BUILD_TYPE=${BUILD_TYPE}")
  set(config_args --config "${BUILD_TYPE}")
  set(ctest_config_args -C "${BUILD_TYPE}")
endif()
if(glm_DIR)
  list(APPEND common_args "-Dglm_DIR=${glm_DIR}")
endif()

file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${WORK_DIR}")
set(consumer_build "${WORK_DIR}/consumer-build")

if(MODE STREQUAL "find_package")
  set(segpath_build "${WORK_DIR}/segpath-build")
  set(staging "${WORK_DIR}/staging")
  set(prefix "${WORK_DIR}/prefix")
  run("configure segpath" ${CMAKE_COMMAND} -S "${SEGPATH_SOURCE_DIR}" -B "${segpath_build}"
      ${common_args} -DSEGPATH_BUILD_TESTS=OFF -DSEGPATH_BUILD_EXAMPLES=OFF
      -DSEGPATH_BUILD_BENCHMARKS=OFF "-DCMAKE_INSTALL_PREFIX=${staging}")
  run("install segpath" ${CMAKE_COMMAND} --install "${segpath_build}" ${config_args})

  foreach(required include/segpath/config.hpp include/segpath/concepts/concepts.hpp
                   share/cmake/segpath/segpathConfig.cmake
                   share/cmake/segpath/segpathConfigVersion.cmake
                   share/cmake/segpath/segpathTargets.cmake)
    if(NOT EXISTS "${staging}/${required}")
      message(FATAL_ERROR "[${MODE}] the install lacks ${required}")
    endif()
  endforeach()
  # The installed package must not point back into the source or build tree.
  file(GLOB package_files "${staging}/share/cmake/segpath/*.cmake")
  foreach(f ${package_files})
    file(READ "${f}" text)
    foreach(tree "${SEGPATH_SOURCE_DIR}" "${segpath_build}" "${staging}")
      string(FIND "${text}" "${tree}" at)
      if(NOT at EQUAL -1)
        message(FATAL_ERROR "[${MODE}] ${f} contains the absolute path ${tree}")
      endif()
    endforeach()
    if(text MATCHES "segpath_project_options")
      message(FATAL_ERROR "[${MODE}] ${f} exports the internal target segpath_project_options")
    endif()
  endforeach()
  file(RENAME "${staging}" "${prefix}")

  run("configure consumer" ${CMAKE_COMMAND} -S "${CONSUMER_DIR}" -B "${consumer_build}"
      ${common_args} "-DCMAKE_PREFIX_PATH=${prefix}")
  # The consumer must have found this install, not one elsewhere on the system.
  file(STRINGS "${consumer_build}/CMakeCache.txt" found REGEX "^segpath_DIR:")
  string(FIND "${found}" "${prefix}/" at)
  if(NOT at GREATER -1)
    message(FATAL_ERROR "[${MODE}] the consumer found another segpath: ${found}")
  endif()
elseif(MODE STREQUAL "subdirectory")
  run("configure consumer" ${CMAKE_COMMAND} -S "${CONSUMER_DIR}" -B "${consumer_build}"
      ${common_args} "-DSEGPATH_SOURCE_DIR=${SEGPATH_SOURCE_DIR}")
else()
  message(FATAL_ERROR "run_consumer.cmake: unknown MODE '${MODE}'")
endif()

run("build consumer" ${CMAKE_COMMAND} --build "${consumer_build}" ${config_args})
run("run consumer" ${CMAKE_CTEST_COMMAND} --test-dir "${consumer_build}" ${ctest_config_args}
    --output-on-failure --no-tests=error)
message(STATUS "[${MODE}] passed")
