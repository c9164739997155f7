# The `placedb` command line. Everything but main() lives in placedb_cli so tests/cli can test the
# parts (eval, sources, settings, log) directly; the executable lands in ${CMAKE_BINARY_DIR}/tools.
find_package(PkgConfig REQUIRED)
pkg_check_modules(PLPLOT REQUIRED IMPORTED_TARGET plplot)

add_library(placedb_cli STATIC
  ${CMAKE_CURRENT_LIST_DIR}/src/exit_codes.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/text_file.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/base64.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/whole_file.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/interrupt.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/settings_input.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/calibration_file.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/frame_log.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/log_recovery.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/frame_names.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/progress.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/map_argument.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/output_guard.cpp)
# Those are the plumbing every room may use; the rooms list their own files. Includes are written
# from src/ ("sources/image_source.h"), as the tests, benches, fuzzers and bindings write them.
include(${CMAKE_CURRENT_LIST_DIR}/src/sources/sources.cmake)
include(${CMAKE_CURRENT_LIST_DIR}/src/report/sources.cmake)
include(${CMAKE_CURRENT_LIST_DIR}/src/commands/sources.cmake)
target_include_directories(placedb_cli PUBLIC ${CMAKE_CURRENT_LIST_DIR}/src)
# The vocab command uses an engine internal (the vocabulary file); the demo renders synthetic
# sequences.
target_link_libraries(placedb_cli
  PUBLIC placedb_engine placedb_storage CLI11::CLI11 fmt::fmt nlohmann_json::nlohmann_json
         ${OpenCV_LIBS}
  PRIVATE placedb_engine_internal placedb_synthetic PkgConfig::PLPLOT placedb_build_flags
          placedb_version)

# ROS 1 bags through the ROS project's reader (Debian's librosbag-storage-dev). Its headers
# include pluginlib, which on Debian 12 comes from ROS 2 and needs four more header folders; its
# CMake config needs ament's Python tools, so the pieces are found here one by one. Without them
# placedb builds and a .bag source is a clear error.
find_path(PLACEDB_ROSBAG_INCLUDE rosbag/bag.h)
find_library(PLACEDB_ROSBAG_LIB rosbag_storage)
set(PLACEDB_ROSBAG_HEADER_DIRS)
foreach(dir pluginlib class_loader rcpputils rcutils ament_index_cpp)
  if(EXISTS /usr/include/${dir})
    list(APPEND PLACEDB_ROSBAG_HEADER_DIRS /usr/include/${dir})
  endif()
endforeach()
list(LENGTH PLACEDB_ROSBAG_HEADER_DIRS PLACEDB_ROSBAG_HEADER_COUNT)
if(PLACEDB_ROSBAG_INCLUDE AND PLACEDB_ROSBAG_LIB AND PLACEDB_ROSBAG_HEADER_COUNT EQUAL 5)
  target_compile_definitions(placedb_cli PRIVATE PLACEDB_WITH_ROS1_BAGS)
  target_include_directories(placedb_cli SYSTEM PRIVATE ${PLACEDB_ROSBAG_HEADER_DIRS})
  target_link_libraries(placedb_cli PRIVATE rosbag_storage roscpp_serialization rostime
                        cpp_common console_bridge)
  set(PLACEDB_WITH_ROS1_BAGS ON CACHE INTERNAL "")
  message(STATUS "ROS 1 bags: read with ${PLACEDB_ROSBAG_LIB}")
else()
  set(PLACEDB_WITH_ROS1_BAGS OFF CACHE INTERNAL "")
  message(STATUS "ROS 1 bags: not read (install librosbag-storage-dev and its headers)")
endif()

add_executable(placedb ${CMAKE_CURRENT_LIST_DIR}/src/commands/main.cpp)
# main() checks PLACEDB_SIMD (an engine internal) before any command writes a file.
target_link_libraries(placedb PRIVATE placedb_cli placedb_engine_internal placedb_build_flags
                      placedb_version)
set_target_properties(placedb PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tools)
