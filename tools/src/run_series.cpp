#include "run_series.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <map>

#include "placedb/error.h"
#include "placedb/storage/map_store.h"

namespace placedb::cli {
namespace {

// The column as numbers, or empty when the log lacks it or a cell is not a number.
std::vector<double> numericColumn(const CsvTable& log, const std::string& name) {
  int column = log.column(name);
  if (column < 0) return {};
  std::vector<double> values;
  for (std::size_t i = 0; i < log.rows.size(); ++i) {
    const std::string& cell = log.cell(i, column);
    char* end = nullptr;
    double v = std::strtod(cell.c_str(), &end);
    if (cell.empty() || end == cell.c_str()) return {};
    values.push_back(v);
  }
  return values;
}

void fillFromMap(RunSeries& series, const std::string& map_path,
                 std::optional<std::int64_t> session) {
  storage::MapStore store(map_path, storage::OpenMode::kReadOnly);
  if (!session) {
    auto last = store.lastSession();
    if (!last)
      throw Error(ErrorCode::kInvalidArgument, fmt::format("map {} has no session", map_path));
    session = last->id;
  }
  std::map<std::int64_t, storage::FrameRecord> by_index;
  for (auto& frame : store.frames(*session)) by_index[frame.source_index] = frame;
  auto from_map = [&](std::vector<double>& target, auto get) {
    if (!target.empty()) return;
    for (double f : series.frame) {
      auto it = by_index.find(static_cast<std::int64_t>(f));
      target.push_back(it == by_index.end() ? 0.0 : get(it->second));
    }
  };
  from_map(series.vocabulary_size, [](const storage::FrameRecord& r) {
    return static_cast<double>(r.stats.vocabulary_size);
  });
  from_map(series.mean_quantisation_error,
           [](const storage::FrameRecord& r) { return r.stats.mean_quantisation_error; });
  from_map(series.wm_size,
           [](const storage::FrameRecord& r) { return static_cast<double>(r.stats.wm_size); });
  from_map(series.time_ms, [](const storage::FrameRecord& r) { return r.timings.total_ms; });
}

}  // namespace

RunSeries buildRunSeries(const CsvTable& log, const Evaluation& eval, const GroundTruth& gt,
                         const std::string& map_path, std::optional<std::int64_t> session) {
  RunSeries series;
  for (const auto& f : eval.frames) {
    series.frame.push_back(static_cast<double>(f.frame));
    series.score.push_back(f.score);
    if (f.accepted) series.accepted_frames.push_back(static_cast<double>(f.frame));
    if (gt.count(f.frame)) series.gt_loop_frames.push_back(static_cast<double>(f.frame));
  }
  series.vocabulary_size = numericColumn(log, "vocabulary_size");
  series.mean_quantisation_error = numericColumn(log, "mean_quantisation_error");
  series.wm_size = numericColumn(log, "wm_size");
  series.time_ms = numericColumn(log, "time_ms");
  if (!map_path.empty()) fillFromMap(series, map_path, session);
  // A bad frame has no hypothesis, words or tiers of its own: its figures are gaps, not zeros.
  // Its time is real and stays.
  const int outcome = log.column("outcome");
  if (outcome >= 0 && log.rows.size() == series.frame.size()) {
    for (std::size_t i = 0; i < log.rows.size(); ++i) {
      if (log.cell(i, outcome) != "bad") continue;
      for (auto* values : {&series.score, &series.vocabulary_size, &series.mean_quantisation_error,
                           &series.wm_size})
        if (i < values->size()) (*values)[i] = std::nan("");
    }
  }
  return series;
}

}  // namespace placedb::cli
