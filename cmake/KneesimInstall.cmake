# Install and export, MuJoCo-style: kneesim::engine, a package config and a version file.
# Components: "engine" (library, headers, CMake package: all a plugin author needs), "plugins",
# "data"; the kneesim command has none. `cmake --install <build> --component engine` needs only the
# kneesim_engine target built.
include(CMakePackageConfigHelpers)

install(TARGETS kneesim_engine EXPORT kneesimTargets
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT engine
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT engine
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT engine
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/kneesim)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/engine/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/kneesim
  COMPONENT engine FILES_MATCHING PATTERN "*.hpp" PATTERN "*.h"
  PATTERN "*_detail.hpp" EXCLUDE PATTERN "*_internal.hpp" EXCLUDE)  # internal to a module's files
install(EXPORT kneesimTargets NAMESPACE kneesim:: FILE kneesimTargets.cmake
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/kneesim COMPONENT engine)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/kneesimConfig.cmake.in
  ${PROJECT_BINARY_DIR}/kneesimConfig.cmake
  INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/kneesim
  PATH_VARS CMAKE_INSTALL_LIBDIR)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/kneesimConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMajorVersion)
install(FILES ${PROJECT_BINARY_DIR}/kneesimConfig.cmake ${PROJECT_BINARY_DIR}/kneesimConfigVersion.cmake
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/kneesim COMPONENT engine)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/share/ DESTINATION ${CMAKE_INSTALL_DATADIR}/kneesim COMPONENT data)
