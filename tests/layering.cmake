# The include layering of the library (run as cmake -DINCLUDE_DIR=... -P layering.cmake):
# core/ includes only core/, concepts/ only core/ and concepts/. Everything else builds on
# these two, so a header of core/ or concepts/ that includes from above is an upward
# dependency (e.g. the contribution functions need the concepts: they live in integrand/).
set(allowed_core "core")
set(allowed_concepts "core|concepts")
set(violations "")
foreach(layer core concepts)
  file(GLOB headers ${INCLUDE_DIR}/segpath/${layer}/*.hpp)
  foreach(header ${headers})
    file(STRINGS ${header} includes REGEX "^#include \"segpath/[^/\"]+/")  # config.hpp is no layer
    foreach(line ${includes})
      string(REGEX REPLACE "^#include \"segpath/([^/\"]+)/.*$" "\\1" folder "${line}")
      if(NOT folder MATCHES "^(${allowed_${layer}})$")
        list(APPEND violations "${header}: ${line}")
      endif()
    endforeach()
  endforeach()
endforeach()
if(violations)
  list(JOIN violations "\n  " text)
  message(FATAL_ERROR "upward includes:\n  ${text}")
endif()
message(STATUS "layering: core/ and concepts/ include nothing from above")
