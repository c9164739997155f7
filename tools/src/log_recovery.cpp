#include "log_recovery.h"

#include <algorithm>

#include "placedb/storage/map_store.h"

namespace placedb::cli {

std::vector<FrameResult> framesFromMap(const std::string& map_path, std::int64_t session,
                                       std::optional<std::int64_t> after, std::int64_t before) {
  std::vector<FrameResult> out;
  const auto store = storage::openMapStore(map_path, storage::OpenMode::kReadOnly);
  const auto snapshot = store->readSnapshot();
  for (const storage::FrameRecord& f : store->frames(session)) {
    if ((after && f.source_index <= *after) || f.source_index >= before) continue;
    FrameResult r;
    r.frame_id = f.id;
    r.session_id = f.session_id;
    r.source_index = f.source_index;
    r.stamp_ns = f.stamp_ns;
    r.outcome = static_cast<FrameOutcome>(f.outcome);
    r.location_id = f.location_id.value_or(0);
    const storage::FrameTimings& t = f.timings;
    r.times = {t.features_ms, t.quantisation_ms, t.likelihood_ms, t.filter_ms,
               t.memory_ms,   t.storage_ms,      t.total_ms};
    r.feature_count = static_cast<std::size_t>(f.stats.feature_count);
    r.words_created = static_cast<std::size_t>(f.stats.words_created);
    r.vocabulary_size = static_cast<std::size_t>(f.stats.vocabulary_size);
    r.wm_size = static_cast<std::size_t>(f.stats.wm_size);
    r.stm_size = static_cast<std::size_t>(f.stats.stm_size);
    r.mean_quantisation_error = f.stats.mean_quantisation_error;
    if (r.outcome == FrameOutcome::kBad) r.hypothesis.rejected_reason = "bad frame";
    if (const auto h = store->hypothesis(f.id)) {
      r.hypothesis.posterior = h->posterior;
      r.hypothesis.score = h->loop_probability;
      r.hypothesis.accepted = h->accepted;
      r.hypothesis.rejected_reason = h->rejected_reason;
      r.hypothesis.pose = h->pose;
      if (h->best_location_id) {
        r.hypothesis.location_id = *h->best_location_id;
        // The location's frames then: those committed up to this frame (frame ids grow with
        // every commit of a file, and of a lone writer on a server).
        for (std::int64_t id : store->coveredFrames(*h->best_location_id)) {
          const auto covered = id <= f.id ? store->frame(id) : std::nullopt;
          if (covered)
            r.hypothesis.frames.push_back({covered->id, covered->session_id, covered->source_index,
                                           covered->source_path, covered->stamp_ns});
        }
        std::sort(r.hypothesis.frames.begin(), r.hypothesis.frames.end(),
                  [](const FrameRef& a, const FrameRef& b) { return a.frame_id < b.frame_id; });
      }
    }
    out.push_back(std::move(r));
  }
  return out;
}

}  // namespace placedb::cli
