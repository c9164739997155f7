#pragma once
// The engine's own counters and the vocabulary's index state, as kept in the map's engine_state
// table so that a reopened map continues exactly where the last committed frame left it.
#include <cstdint>
#include <string>
#include <vector>

#include "decision/closure_evidence.h"
#include "decision/closure_run.h"
#include "decision/way_here.h"
#include "placedb/storage/map_store.h"
#include "vocabulary/vocabulary.h"

namespace placedb {

struct EngineCounters {
  std::int64_t next_frame_id = 1;
  std::int64_t next_location_id = 1;
  std::int64_t feature_sum = 0;  // features over good frames: the bad-frame running mean
  std::int64_t feature_frames = 0;
  std::int64_t last_location = 0;    // newest location of the current session, 0 = none
  std::int64_t last_session = 0;     // session that last_location belongs to
  double previous_score = 0;         // the filter's ratio-test memory
  ClosureRun closure_run;            // the loop closures a revisit is making
  ClosureEvidence closure_evidence;  // the check's evidence over the newest frames
  RefutedPlace refuted;              // the newest place refused as a pattern (way_here.h)
  std::int64_t next_wm_age = 1;      // the memory tiers' age clock (next_location_id on older maps)
  // Where the blocks of ids this writer reserved end (map_fleet.cpp), 0: no block. A file's
  // writer hands ids out without one; a writer of a server map reserves blocks, since other
  // writers may hand out ids at the same time.
  std::int64_t frame_block_end = 0;
  std::int64_t location_block_end = 0;
  std::int64_t word_block_end = 0;
  // The frame ids this session skipped to reach its blocks: closure runs and evidence count
  // frames by their clock, frame id - frame_clock_shift, which a jump to a new block leaves
  // continuous. 0 for a lone writer, whose blocks follow each other.
  std::int64_t frame_clock_shift = 0;
  // Which locations were in STM and WM after the last frame (map_structure.h's tiersDigest), so
  // that a tier changed by hand is found when the map opens; 0 on maps made before.
  std::int64_t tiers_digest = 0;

  void save(storage::MapStore& store) const;
  // False when the map holds no engine state yet (a new map).
  bool load(const storage::MapStore& store);
};

// The vocabulary's index state: a small header in engine_state and the kd-forest's internal nodes
// in kd_nodes, of which a frame writes only those that changed. Maps of schema 2 stored an
// append-only split log in engine_state chunks instead; load() reads it for conversion and the
// next save() replaces it with the node table.
class VocabularyStateWriter {
 public:
  static constexpr std::size_t kSplitsPerChunk = 1024;  // of the schema-2 split log

  // Writes what changed since the last save() or load() (takes the vocabulary's index changes).
  void save(storage::MapStore& store, vocab::Vocabulary& vocabulary);
  // Empty optional when the map holds no vocabulary state. kMapRefused on damaged state.
  std::optional<vocab::IndexState> load(const storage::MapStore& store);

 private:
  std::int64_t saved_next_word_id_ = -1;
  std::size_t legacy_chunks_ = 0;  // split-log chunks still in the file, dropped by save()
  vocab::ForestChanges changes_;   // reused every frame
  std::vector<storage::KdNodeRecord> upserts_;
  std::vector<std::pair<int, std::int64_t>> deletions_;
};

}  // namespace placedb
