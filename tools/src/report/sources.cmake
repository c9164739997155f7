# What a run is worth: the scoring against ground truth, plots, the loop matrix, the HTML report
# and the pose graph's export.
target_sources(placedb_cli PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/eval.cpp
  ${CMAKE_CURRENT_LIST_DIR}/evaluation_run.cpp
  ${CMAKE_CURRENT_LIST_DIR}/plots.cpp
  ${CMAKE_CURRENT_LIST_DIR}/loop_matrix.cpp
  ${CMAKE_CURRENT_LIST_DIR}/run_series.cpp
  ${CMAKE_CURRENT_LIST_DIR}/report.cpp
  ${CMAKE_CURRENT_LIST_DIR}/report_page.cpp
  ${CMAKE_CURRENT_LIST_DIR}/graph_export.cpp
  ${CMAKE_CURRENT_LIST_DIR}/pose_track.cpp)
