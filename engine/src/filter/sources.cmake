# Loop-closure core: signatures, inverted index, link graph, Bayes filter and its decision rule.
target_sources(placedb_engine PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/signature.cpp
  ${CMAKE_CURRENT_LIST_DIR}/inverted_index.cpp
  ${CMAKE_CURRENT_LIST_DIR}/link_graph.cpp
  ${CMAKE_CURRENT_LIST_DIR}/filter_settings.cpp
  ${CMAKE_CURRENT_LIST_DIR}/transition_model.cpp
  ${CMAKE_CURRENT_LIST_DIR}/bayes_filter.cpp)
