# Memory tiers: STM / WM / LTM membership, weights, transfer and retrieval choices.
target_sources(placedb_engine PRIVATE ${CMAKE_CURRENT_LIST_DIR}/memory_tiers.cpp
                                      ${CMAKE_CURRENT_LIST_DIR}/place_code.cpp
                                      ${CMAKE_CURRENT_LIST_DIR}/place_index.cpp
                                      ${CMAKE_CURRENT_LIST_DIR}/place_lists.cpp
                                      ${CMAKE_CURRENT_LIST_DIR}/place_neighbourhood.cpp)
