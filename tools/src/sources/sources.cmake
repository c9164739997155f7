# Where frames come from: a folder, a list, a video, a ROS 1 or ROS 2 bag (its image messages
# decoded here), or a live stream.
target_sources(placedb_cli PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/image_source.cpp
  ${CMAKE_CURRENT_LIST_DIR}/image_message.cpp
  ${CMAKE_CURRENT_LIST_DIR}/bag_source.cpp
  ${CMAKE_CURRENT_LIST_DIR}/ros1_bag.cpp
  ${CMAKE_CURRENT_LIST_DIR}/ros2_bag.cpp
  ${CMAKE_CURRENT_LIST_DIR}/live_source.cpp
  ${CMAKE_CURRENT_LIST_DIR}/mjpeg_stream.cpp)
