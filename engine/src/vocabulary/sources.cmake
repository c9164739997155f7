target_sources(placedb_engine PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/slot_store.cpp
  ${CMAKE_CURRENT_LIST_DIR}/kd_forest.cpp
  ${CMAKE_CURRENT_LIST_DIR}/kd_forest_nodes.cpp
  ${CMAKE_CURRENT_LIST_DIR}/kd_forest_search.cpp
  ${CMAKE_CURRENT_LIST_DIR}/vocabulary.cpp
  ${CMAKE_CURRENT_LIST_DIR}/index_state.cpp
  ${CMAKE_CURRENT_LIST_DIR}/vocabulary_file.cpp)
