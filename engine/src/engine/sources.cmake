target_sources(placedb_engine PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/candidate_choice.cpp
  ${CMAKE_CURRENT_LIST_DIR}/closure_run.cpp
  ${CMAKE_CURRENT_LIST_DIR}/descriptor_match.cpp
  ${CMAKE_CURRENT_LIST_DIR}/engine_state.cpp
  ${CMAKE_CURRENT_LIST_DIR}/epipolar_fit.cpp
  ${CMAKE_CURRENT_LIST_DIR}/geometric_check.cpp
  ${CMAKE_CURRENT_LIST_DIR}/keypoint_cache.cpp
  ${CMAKE_CURRENT_LIST_DIR}/option_mapping.cpp
  ${CMAKE_CURRENT_LIST_DIR}/map_import.cpp
  ${CMAKE_CURRENT_LIST_DIR}/map_open.cpp
  ${CMAKE_CURRENT_LIST_DIR}/map_process.cpp
  ${CMAKE_CURRENT_LIST_DIR}/map_query.cpp
  ${CMAKE_CURRENT_LIST_DIR}/map_verify.cpp
  ${CMAKE_CURRENT_LIST_DIR}/relative_pose.cpp)
# The geometric check's fundamental matrix (OpenCV's imported target exists once OpenCV is found).
target_link_libraries(placedb_engine PRIVATE opencv_calib3d)
