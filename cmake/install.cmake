# What `cmake --install build --prefix P` puts under P: the placedb command line, the public
# headers, the static libraries with a CMake package (find_package(placedb CONFIG) ->
# placedb::placedb) and a pkg-config file. Included by the top-level CMakeLists.txt after the
# targets exist.
include(CMakePackageConfigHelpers)

set(PLACEDB_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/placedb)

install(TARGETS placedb RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(TARGETS placedb_engine placedb_storage EXPORT placedbTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/engine/include/placedb
                  ${PROJECT_SOURCE_DIR}/storage/include/placedb
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})

install(EXPORT placedbTargets NAMESPACE placedb:: DESTINATION ${PLACEDB_CMAKE_DIR})
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/placedbConfig.cmake.in
                              ${CMAKE_CURRENT_BINARY_DIR}/placedbConfig.cmake
                              INSTALL_DESTINATION ${PLACEDB_CMAKE_DIR})
# 0.x: a minor release may change the API.
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/placedbConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/placedbConfig.cmake
              ${CMAKE_CURRENT_BINARY_DIR}/placedbConfigVersion.cmake
        DESTINATION ${PLACEDB_CMAKE_DIR})

# The .pc file finds its prefix from its own folder, so the tree can be installed anywhere.
file(RELATIVE_PATH PLACEDB_PC_PREFIX "/${CMAKE_INSTALL_LIBDIR}/pkgconfig" "/")
string(REGEX REPLACE "/$" "" PLACEDB_PC_PREFIX "${PLACEDB_PC_PREFIX}")
configure_file(${CMAKE_CURRENT_LIST_DIR}/placedb.pc.in ${CMAKE_CURRENT_BINARY_DIR}/placedb.pc @ONLY)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/placedb.pc
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
install(FILES ${PROJECT_SOURCE_DIR}/LICENSE DESTINATION ${CMAKE_INSTALL_DOCDIR})
