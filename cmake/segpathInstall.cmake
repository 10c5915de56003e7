# Installation: headers, the exported INTERFACE target, a package config and version file
# so that consumers can `find_package(segpath CONFIG)`.
include(CMakePackageConfigHelpers)
set(SEGPATH_INSTALL_CMAKEDIR ${CMAKE_INSTALL_DATADIR}/cmake/segpath)

install(TARGETS segpath EXPORT segpathTargets)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/segpath DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
  FILES_MATCHING PATTERN "*.hpp" PATTERN "*.inl")
install(EXPORT segpathTargets NAMESPACE segpath:: DESTINATION ${SEGPATH_INSTALL_CMAKEDIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/segpathConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/segpathConfig.cmake
  INSTALL_DESTINATION ${SEGPATH_INSTALL_CMAKEDIR})
# Header-only: the version file must not pin the consumer's pointer size.
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/segpathConfigVersion.cmake
  COMPATIBILITY SameMinorVersion ARCH_INDEPENDENT)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/segpathConfig.cmake
  ${CMAKE_CURRENT_BINARY_DIR}/segpathConfigVersion.cmake
  DESTINATION ${SEGPATH_INSTALL_CMAKEDIR})
