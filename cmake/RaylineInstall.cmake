# `cmake --install build --prefix P` (docs/library.md):
#   P/bin/rayline
#   P/share/rayline/platforms/*.json, P/share/rayline/scenes/*.json (read by the installed
#     binary through apps/data_dir.cpp; scenes/assets/ is left out: its meshes are fetched
#     into the source tree only)
#   P/include/rayline/{common,sched}/...  the scheduling library's headers
#   P/lib/librayline_{common,sched}.a
#   P/lib/cmake/Rayline/  the CMake package: find_package(Rayline) gives Rayline::sched
#     (and Rayline::common, which it links)
#   P/share/doc/rayline/  README.md, CHANGELOG.md, LICENSE
include(CMakePackageConfigHelpers)

set(RAYLINE_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/Rayline)

if(TARGET rayline)
  install(TARGETS rayline RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
endif()
install(DIRECTORY ${PROJECT_SOURCE_DIR}/platforms/ DESTINATION ${CMAKE_INSTALL_DATADIR}/rayline/platforms
        FILES_MATCHING PATTERN "*.json" PATTERN "README.md")
install(DIRECTORY ${PROJECT_SOURCE_DIR}/scenes/ DESTINATION ${CMAKE_INSTALL_DATADIR}/rayline/scenes
        FILES_MATCHING PATTERN "*.json" PATTERN "README.md" PATTERN "assets" EXCLUDE)

# The library: rayline_sched and rayline_common, static, with their headers. Their link
# interface holds only each other: nlohmann_json and Eigen are used inside .cpp files.
install(TARGETS rayline_common rayline_sched EXPORT RaylineTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/sched/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/rayline/sched
        FILES_MATCHING PATTERN "*.hpp")
# common/json_fields.hpp names nlohmann_json's types; it serves the loaders inside the
# libraries only, and is not installed, so the package needs no third-party package.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/common/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/rayline/common
        FILES_MATCHING PATTERN "*.hpp" PATTERN "json_fields.hpp" EXCLUDE)
install(EXPORT RaylineTargets NAMESPACE Rayline:: DESTINATION ${RAYLINE_CMAKE_DIR})

configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/RaylineConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/RaylineConfig.cmake INSTALL_DESTINATION ${RAYLINE_CMAKE_DIR}
                              PATH_VARS CMAKE_INSTALL_DATADIR)
# 0.x: a minor release may change the API, so only the same major.minor is compatible.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/RaylineConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/RaylineConfig.cmake ${PROJECT_BINARY_DIR}/RaylineConfigVersion.cmake
        DESTINATION ${RAYLINE_CMAKE_DIR})

install(FILES ${PROJECT_SOURCE_DIR}/README.md ${PROJECT_SOURCE_DIR}/CHANGELOG.md ${PROJECT_SOURCE_DIR}/LICENSE
        DESTINATION ${CMAKE_INSTALL_DOCDIR})
