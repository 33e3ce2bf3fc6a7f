# Install and export, MuJoCo-style: kneesim::engine, a package config and a version file.
include(CMakePackageConfigHelpers)

install(TARGETS kneesim_engine EXPORT kneesimTargets
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/kneesim)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/engine/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/kneesim
  FILES_MATCHING PATTERN "*.hpp" PATTERN "*.h")
install(EXPORT kneesimTargets NAMESPACE kneesim:: FILE kneesimTargets.cmake
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/kneesim)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/kneesimConfig.cmake.in
  ${PROJECT_BINARY_DIR}/kneesimConfig.cmake
  INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/kneesim
  PATH_VARS CMAKE_INSTALL_LIBDIR)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/kneesimConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMajorVersion)
install(FILES ${PROJECT_BINARY_DIR}/kneesimConfig.cmake ${PROJECT_BINARY_DIR}/kneesimConfigVersion.cmake
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/kneesim)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/share/ DESTINATION ${CMAKE_INSTALL_DATADIR}/kneesim)
