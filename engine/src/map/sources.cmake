# The map's life: open, process a frame, query, import a vocabulary, and the state it keeps.
set(_placedb_map_sources
  ${CMAKE_CURRENT_LIST_DIR}/engine_state.cpp
  ${CMAKE_CURRENT_LIST_DIR}/option_mapping.cpp
  ${CMAKE_CURRENT_LIST_DIR}/map_fleet.cpp
  ${CMAKE_CURRENT_LIST_DIR}/map_import.cpp
  ${CMAKE_CURRENT_LIST_DIR}/map_open.cpp
  ${CMAKE_CURRENT_LIST_DIR}/map_structure.cpp
  ${CMAKE_CURRENT_LIST_DIR}/map_process.cpp
  ${CMAKE_CURRENT_LIST_DIR}/map_query.cpp
  ${CMAKE_CURRENT_LIST_DIR}/map_verify.cpp
  ${CMAKE_CURRENT_LIST_DIR}/paired_checks.cpp
  ${CMAKE_CURRENT_LIST_DIR}/read_ahead.cpp)
target_sources(placedb_engine PRIVATE ${_placedb_map_sources})
