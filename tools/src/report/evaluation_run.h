#pragma once
// A log scored and plotted: what `placedb eval`, `placedb demo` and the report run.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "report/eval.h"
#include "report/plots.h"

namespace placedb::cli {

struct EvalRequest {
  std::filesystem::path log, gt;
  int window = 0;
  std::filesystem::path plots_dir;  // empty: no plots
  std::string map_path;             // empty: series from the log only
  std::optional<std::int64_t> session;
};

struct EvalOutcome {
  Evaluation evaluation;
  std::vector<WrittenPlot> plots;
};

EvalOutcome runEvaluation(const EvalRequest& request);

}  // namespace placedb::cli
