# Install rules: one export set per component, so that find_package(sph COMPONENTS model)
# needs Eigen only, COMPONENTS core adds nothing else, COMPONENTS can (Linux) neither, and
# COMPONENTS calib needs Ceres.
include(CMakePackageConfigHelpers)

set(SPH_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/sph" CACHE STRING "Where sphConfig.cmake is installed")

install(DIRECTORY include/sph/model include/sph/c DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}/sph" COMPONENT model)
install(TARGETS sph_model sph_c EXPORT sph-model-targets ARCHIVE DESTINATION "${CMAKE_INSTALL_LIBDIR}"
        LIBRARY DESTINATION "${CMAKE_INSTALL_LIBDIR}")
install(EXPORT sph-model-targets NAMESPACE sph:: DESTINATION "${SPH_INSTALL_CMAKEDIR}" COMPONENT model)

install(DIRECTORY include/sph/core include/sph/io include/sph/simulation include/sph/stats include/sph/measure include/sph/sphere DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}/sph" COMPONENT core)
install(TARGETS sph_sphere sph_core EXPORT sph-core-targets ARCHIVE DESTINATION "${CMAKE_INSTALL_LIBDIR}"
        LIBRARY DESTINATION "${CMAKE_INSTALL_LIBDIR}")
install(EXPORT sph-core-targets NAMESPACE sph:: DESTINATION "${SPH_INSTALL_CMAKEDIR}" COMPONENT core)

if(TARGET sph_can)
  install(DIRECTORY include/sph/can DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}/sph" COMPONENT can)
  install(TARGETS sph_can EXPORT sph-can-targets ARCHIVE DESTINATION "${CMAKE_INSTALL_LIBDIR}"
          LIBRARY DESTINATION "${CMAKE_INSTALL_LIBDIR}")
  install(EXPORT sph-can-targets NAMESPACE sph:: DESTINATION "${SPH_INSTALL_CMAKEDIR}" COMPONENT can)
endif()

if(SPH_BUILD_CALIBRATION)
  install(DIRECTORY include/sph/ceres include/sph/calib include/sph/select DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}/sph" COMPONENT calib)
  install(TARGETS sph_calib EXPORT sph-calib-targets ARCHIVE DESTINATION "${CMAKE_INSTALL_LIBDIR}"
          LIBRARY DESTINATION "${CMAKE_INSTALL_LIBDIR}")
  install(EXPORT sph-calib-targets NAMESPACE sph:: DESTINATION "${SPH_INSTALL_CMAKEDIR}" COMPONENT calib)
endif()

configure_package_config_file(cmake/sphConfig.cmake.in "${PROJECT_BINARY_DIR}/sphConfig.cmake"
                              INSTALL_DESTINATION "${SPH_INSTALL_CMAKEDIR}")
write_basic_package_version_file("${PROJECT_BINARY_DIR}/sphConfigVersion.cmake" COMPATIBILITY SameMajorVersion)
install(FILES "${PROJECT_BINARY_DIR}/sphConfig.cmake" "${PROJECT_BINARY_DIR}/sphConfigVersion.cmake"
        DESTINATION "${SPH_INSTALL_CMAKEDIR}")
