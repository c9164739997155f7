#include "report/run_series.h"

#include <fmt/format.h>

#include <algorithm>
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
  const auto store_owner = storage::openMapStore(map_path, storage::OpenMode::kReadOnly);
  storage::MapStore& store = *store_owner;
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
  if (!series.stages.empty()) return;
  // The map keeps no verification time of its own: it stays inside the filter's.
  const std::pair<const char*, double storage::FrameTimings::*> kMapStages[] = {
      {"features", &storage::FrameTimings::features_ms},
      {"quantisation", &storage::FrameTimings::quantisation_ms},
      {"likelihood", &storage::FrameTimings::likelihood_ms},
      {"filter", &storage::FrameTimings::filter_ms},
      {"memory", &storage::FrameTimings::memory_ms},
      {"storage", &storage::FrameTimings::storage_ms}};
  for (const auto& [name, member] : kMapStages) {
    RunSeries::Stage stage{name, {}};
    from_map(stage.ms,
             [member = member](const storage::FrameRecord& r) { return r.timings.*member; });
    series.stages.push_back(std::move(stage));
  }
}

// The log's stage columns in stacking order. The geometric check's time is part of filter_ms;
// it is shown as a stage of its own and taken out of the filter's.
std::vector<RunSeries::Stage> stagesOfLog(const CsvTable& log) {
  std::vector<RunSeries::Stage> stages;
  for (const char* name :
       {"features", "quantisation", "likelihood", "filter", "verification", "memory", "storage"}) {
    std::vector<double> ms = numericColumn(log, std::string(name) + "_ms");
    if (!ms.empty()) stages.push_back({name, std::move(ms)});
  }
  auto find = [&stages](const std::string& name) -> RunSeries::Stage* {
    for (auto& stage : stages)
      if (stage.name == name) return &stage;
    return nullptr;
  };
  RunSeries::Stage* filter = find("filter");
  const RunSeries::Stage* verification = find("verification");
  if (filter && verification)
    for (std::size_t i = 0; i < filter->ms.size(); ++i)
      filter->ms[i] = std::max(0.0, filter->ms[i] - verification->ms[i]);
  return stages;
}

}  // namespace

RunSeries buildRunSeries(const CsvTable& log, const Evaluation& eval, const GroundTruth& gt,
                         const std::string& map_path, std::optional<std::int64_t> session) {
  RunSeries series;
  for (const auto& f : eval.frames) {
    series.frame.push_back(static_cast<double>(f.frame));
    series.score.push_back(f.score);
    const auto x = static_cast<double>(f.frame);
    // As evaluate() counts them: a closure is right when it has a candidate near the truth.
    const bool right = f.accepted && f.correct && !f.candidates.empty();
    if (f.accepted) (right ? series.accepted_right : series.accepted_wrong).push_back(x);
    if (gt.count(f.frame)) {
      series.gt_loop_frames.push_back(x);
      if (!right) series.missed_loops.push_back(x);
    }
  }
  series.vocabulary_size = numericColumn(log, "vocabulary_size");
  series.mean_quantisation_error = numericColumn(log, "mean_quantisation_error");
  series.wm_size = numericColumn(log, "wm_size");
  series.time_ms = numericColumn(log, "time_ms");
  series.stages = stagesOfLog(log);
  if (!map_path.empty()) fillFromMap(series, map_path, session);
  // A bad frame has no hypothesis, words or tiers of its own: its figures are gaps, not zeros.
  // Its total time is real and stays; its stage times are gaps, since it stopped before the
  // stages and a stack of near-zero bars would read as a fast frame.
  const int outcome = log.column("outcome");
  if (outcome >= 0 && log.rows.size() == series.frame.size()) {
    for (std::size_t i = 0; i < log.rows.size(); ++i) {
      if (log.cell(i, outcome) != "bad") continue;
      for (auto* values : {&series.score, &series.vocabulary_size, &series.mean_quantisation_error,
                           &series.wm_size})
        if (i < values->size()) (*values)[i] = std::nan("");
      for (auto& stage : series.stages)
        if (i < stage.ms.size()) stage.ms[i] = std::nan("");
    }
  }
  return series;
}

}  // namespace placedb::cli
