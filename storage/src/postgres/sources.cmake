# The PostgreSQL backend: a map in a database on a server, reached through libpq.
target_sources(placedb_storage PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/pg_connection.cpp
  ${CMAKE_CURRENT_LIST_DIR}/pg_map_check.cpp
  ${CMAKE_CURRENT_LIST_DIR}/pg_pipeline.cpp
  ${CMAKE_CURRENT_LIST_DIR}/pg_map_store.cpp
  ${CMAKE_CURRENT_LIST_DIR}/pg_map_store_words.cpp
  ${CMAKE_CURRENT_LIST_DIR}/pg_map_store_state.cpp
  ${CMAKE_CURRENT_LIST_DIR}/pg_map_store_tables.cpp
  ${CMAKE_CURRENT_LIST_DIR}/pg_map_store_fleet.cpp)
