# The loop-closure decision: choosing among checked candidates, and runs of closures.
set(_placedb_decision_sources
  ${CMAKE_CURRENT_LIST_DIR}/candidate_choice.cpp
  ${CMAKE_CURRENT_LIST_DIR}/closure_evidence.cpp
  ${CMAKE_CURRENT_LIST_DIR}/closure_run.cpp)
target_sources(placedb_engine PRIVATE ${_placedb_decision_sources})
