# Feature extraction: our SURF-64 and OpenCV's SIFT/KAZE/ORB behind one interface.
target_sources(placedb_engine PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/cpu_support.cpp
  ${CMAKE_CURRENT_LIST_DIR}/feature_extractor.cpp
  ${CMAKE_CURRENT_LIST_DIR}/feature_options.cpp
  ${CMAKE_CURRENT_LIST_DIR}/image_conversion.cpp
  ${CMAKE_CURRENT_LIST_DIR}/image_header.cpp
  ${CMAKE_CURRENT_LIST_DIR}/integral_image.cpp
  ${CMAKE_CURRENT_LIST_DIR}/keypoint_ranking.cpp
  ${CMAKE_CURRENT_LIST_DIR}/opencv_extractors.cpp
  ${CMAKE_CURRENT_LIST_DIR}/parallel_for.cpp
  ${CMAKE_CURRENT_LIST_DIR}/surf_descriptor.cpp
  ${CMAKE_CURRENT_LIST_DIR}/surf_detector.cpp
  ${CMAKE_CURRENT_LIST_DIR}/surf_extractor.cpp)
