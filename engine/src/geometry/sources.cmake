# Geometric verification: correspondences, the epipolar fit, the check's rules, relative pose.
set(_placedb_geometry_sources
  ${CMAKE_CURRENT_LIST_DIR}/descriptor_dots.cpp
  ${CMAKE_CURRENT_LIST_DIR}/descriptor_match.cpp
  ${CMAKE_CURRENT_LIST_DIR}/epipolar_fit.cpp
  ${CMAKE_CURRENT_LIST_DIR}/geometric_check.cpp
  ${CMAKE_CURRENT_LIST_DIR}/keypoint_cache.cpp
  ${CMAKE_CURRENT_LIST_DIR}/latest_view.cpp
  ${CMAKE_CURRENT_LIST_DIR}/relative_pose.cpp
  ${CMAKE_CURRENT_LIST_DIR}/scene_extent.cpp)
target_sources(placedb_engine PRIVATE ${_placedb_geometry_sources})
# The geometric check's fundamental matrix (OpenCV's imported target exists once OpenCV is found).
target_link_libraries(placedb_engine PRIVATE opencv_calib3d)
