#include "report/evaluation_run.h"

#include "report/loop_matrix.h"
#include "report/run_series.h"

namespace placedb::cli {

EvalOutcome runEvaluation(const EvalRequest& request) {
  GroundTruth gt = request.gt.empty() ? GroundTruth{} : loadGroundTruth(request.gt);
  CsvTable log = readCsv(request.log);
  EvalOutcome outcome;
  outcome.evaluation = evaluate(log, gt, request.window);
  if (!request.plots_dir.empty()) {
    RunSeries series =
        buildRunSeries(log, outcome.evaluation, gt, request.map_path, request.session);
    series.judged = !request.gt.empty();
    outcome.plots = writePlots(series, outcome.evaluation, request.plots_dir);
    outcome.plots.push_back(
        writeLoopMatrix(outcome.evaluation, gt, request.plots_dir, series.judged));
  }
  return outcome;
}

}  // namespace placedb::cli
