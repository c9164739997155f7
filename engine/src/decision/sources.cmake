# The loop-closure decision: choosing among checked candidates, runs of closures, and the place
# an accepted closure names.
set(_placedb_decision_sources
  ${CMAKE_CURRENT_LIST_DIR}/agreeing_place.cpp
  ${CMAKE_CURRENT_LIST_DIR}/candidate_choice.cpp
  ${CMAKE_CURRENT_LIST_DIR}/closure_evidence.cpp
  ${CMAKE_CURRENT_LIST_DIR}/closure_run.cpp
  ${CMAKE_CURRENT_LIST_DIR}/way_here.cpp)
target_sources(placedb_engine PRIVATE ${_placedb_decision_sources})
