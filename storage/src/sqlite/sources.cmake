# The SQLite backend: a map in one file (with its -wal, -shm and lock side files).
target_sources(placedb_storage PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/database.cpp
  ${CMAKE_CURRENT_LIST_DIR}/kd_node_journal.cpp
  ${CMAKE_CURRENT_LIST_DIR}/sqlite_checksums.cpp
  ${CMAKE_CURRENT_LIST_DIR}/sqlite_location_rows.cpp
  ${CMAKE_CURRENT_LIST_DIR}/sqlite_map_check.cpp
  ${CMAKE_CURRENT_LIST_DIR}/map_file_check.cpp
  ${CMAKE_CURRENT_LIST_DIR}/map_files.cpp
  ${CMAKE_CURRENT_LIST_DIR}/migrations_apply.cpp
  ${CMAKE_CURRENT_LIST_DIR}/sqlite_map_store.cpp
  ${CMAKE_CURRENT_LIST_DIR}/sqlite_map_store_memory.cpp
  ${CMAKE_CURRENT_LIST_DIR}/sqlite_map_store_words.cpp
  ${CMAKE_CURRENT_LIST_DIR}/sqlite_map_store_links.cpp
  ${CMAKE_CURRENT_LIST_DIR}/sqlite_map_store_state.cpp
  ${CMAKE_CURRENT_LIST_DIR}/sqlite_map_store_tables.cpp
  ${CMAKE_CURRENT_LIST_DIR}/sqlite_map_store_fleet.cpp
  ${CMAKE_CURRENT_LIST_DIR}/wal_checkpointer.cpp)
