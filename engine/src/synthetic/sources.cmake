# Synthetic image sequences with exact loop ground truth (demo, scale benchmark, tests).
target_sources(placedb_engine PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/camera_model.cpp
  ${CMAKE_CURRENT_LIST_DIR}/ground_texture.cpp
  ${CMAKE_CURRENT_LIST_DIR}/ground_truth.cpp
  ${CMAKE_CURRENT_LIST_DIR}/route_planner.cpp
  ${CMAKE_CURRENT_LIST_DIR}/sequence_writer.cpp
  ${CMAKE_CURRENT_LIST_DIR}/synthetic_sequence.cpp
  ${CMAKE_CURRENT_LIST_DIR}/tile_painter.cpp)
