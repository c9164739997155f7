# One file per command, the mapping loop they share, and main() (the placedb executable's only
# source, in tools/sources.cmake).
target_sources(placedb_cli PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/mapping_run.cpp
  ${CMAKE_CURRENT_LIST_DIR}/cmd_map.cpp
  ${CMAKE_CURRENT_LIST_DIR}/cmd_query.cpp
  ${CMAKE_CURRENT_LIST_DIR}/cmd_info.cpp
  ${CMAKE_CURRENT_LIST_DIR}/cmd_check.cpp
  ${CMAKE_CURRENT_LIST_DIR}/cmd_vocab.cpp
  ${CMAKE_CURRENT_LIST_DIR}/cmd_eval.cpp
  ${CMAKE_CURRENT_LIST_DIR}/cmd_demo.cpp
  ${CMAKE_CURRENT_LIST_DIR}/cmd_export.cpp
  ${CMAKE_CURRENT_LIST_DIR}/cmd_copy.cpp
  ${CMAKE_CURRENT_LIST_DIR}/cmd_report.cpp)
