#pragma once
// The per-frame series of a run, for plotting: from the log's extra columns, completed from
// the map (its frames table) where the log lacks them, e.g. a log in the bare reference format.
#include <cstdint>
#include <optional>
#include <string>

#include "frame_log.h"
#include "report/eval.h"
#include "report/plots.h"

namespace placedb::cli {

// `map_path` empty: the log alone. `session`: which session of the map the log belongs to
// (default: the last one).
RunSeries buildRunSeries(const CsvTable& log, const Evaluation& eval, const GroundTruth& gt,
                         const std::string& map_path = "",
                         std::optional<std::int64_t> session = std::nullopt);

}  // namespace placedb::cli
