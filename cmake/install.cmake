# cmake --install: the solver library, its headers and the package (hdeform::solver), and the
# engine (hdeform::engine) when it is built. See cmake/hdeformConfig.cmake.in.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)
set(hdeform_package_dir ${CMAKE_INSTALL_LIBDIR}/cmake/hdeform)

install(TARGETS hdeform_solver EXPORT hdeform-solver-targets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(DIRECTORY solver/include/hdeform DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(EXPORT hdeform-solver-targets NAMESPACE hdeform:: DESTINATION ${hdeform_package_dir})
if(TARGET hdeform_engine)
  install(TARGETS hdeform_engine EXPORT hdeform-engine-targets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
  install(DIRECTORY engine/include/hdeform DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  install(FILES shaders/render_config.h DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/hdeform/shaders)
  install(EXPORT hdeform-engine-targets NAMESPACE hdeform:: DESTINATION ${hdeform_package_dir})
endif()

configure_package_config_file(cmake/hdeformConfig.cmake.in ${CMAKE_CURRENT_BINARY_DIR}/hdeformConfig.cmake
                              INSTALL_DESTINATION ${hdeform_package_dir})
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/hdeformConfigVersion.cmake COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/hdeformConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/hdeformConfigVersion.cmake
              cmake/FindCHOLMOD.cmake cmake/FindMETIS.cmake
        DESTINATION ${hdeform_package_dir})
