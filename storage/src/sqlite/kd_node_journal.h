#pragma once
// The kd-forest's changes in a map file: a journal row a frame, folded into kd_nodes a slice of
// node ids at a time (schema 20).
//
// A frame splits ~100 leaves of the forest, and a split's row goes where the leaf's id sorts:
// anywhere in kd_nodes. Written as they come, a frame rewrote ~90 pages of the table for ~4 KB
// of changes, half of every page a frame wrote (bench/quality/README.md). Instead, a frame
// appends its changes as one row of kd_node_journal, and folds into kd_nodes the changes still
// pending whose node ids fall in the next 1/kSweepFrames of the id range, on every tree: rows
// that sit together. Every pending change is folded within one sweep, so the journal holds about
// kSweepFrames frames of changes; a journal row goes once no pending change needs it.
//
// Reading the forest: kd_nodes, then the journal's rows in order, the last change of a node
// winning. That is exact whatever a crash interrupted: a node's latest change is either folded
// (and its later rows, if any, are still journalled) or in a journalled row.
#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <unordered_map>
#include <utility>
#include <vector>

#include "placedb/storage/records.h"

namespace placedb::storage::detail {

using KdNodeKey = std::pair<int, std::int64_t>;  // (tree, node)

// One frame's changes: deletions first, then upserts, as writeKdNodes() applies them.
struct KdNodeChanges {
  std::vector<KdNodeKey> deletions;
  std::vector<KdNodeRecord> upserts;
};

// A journal row's bytes: little-endian records, 13 bytes a deletion (0, tree i32, node i64) and
// 41 an upsert (1, tree i32, node, left, right i64, split_dim i32, split_value f64).
std::vector<std::uint8_t> packKdNodeChanges(const KdNodeChanges& changes);
// False when the bytes are not whole records of that form.
bool unpackKdNodeChanges(const std::uint8_t* data, std::size_t size, KdNodeChanges* out);

class Statement;

// A kd_node_journal row as selected (seq, changes, checksum): its changes into `out`, or what is
// wrong with it, for a refusal or a check's finding; nullptr when nothing is.
const char* kdNodeJournalRowProblem(const Statement& row, KdNodeChanges* out);

// Applies `changes` to a forest held by key, in their order.
void applyKdNodeChanges(const KdNodeChanges& changes, std::map<KdNodeKey, KdNodeRecord>* nodes);

// The writer's changes journalled but not yet folded into kd_nodes, by blocks of node ids.
class PendingKdNodes {
 public:
  // Node ids a frame's fold covers: 1/kSweepFrames of the largest id seen (whole blocks). A
  // frame then rewrites about 1/kSweepFrames of kd_nodes' pages and a reopen replays at most
  // about as many frames of changes. 256: a 100k-node forest (lip6, the 20k-frame scale map)
  // folds ~100 rows a frame in 4 runs of adjacent rows, and the journal stays near 1 MB.
  static constexpr std::int64_t kSweepFrames = 256;
  static constexpr std::int64_t kBlockNodes = 64;

  // Journal row `seq` holds `changes`; rows come in ascending seq, one apart.
  void record(std::int64_t seq, const KdNodeChanges& changes);
  // The pending changes of the next slice of node ids, each node's latest, in key order; they
  // are no longer pending.
  KdNodeChanges takeNextSlice();
  // The oldest journal row that a pending change still needs; `next_seq` when none.
  std::int64_t oldestNeeded(std::int64_t next_seq) const;
  bool empty() const { return needed_.empty(); }
  void clear();

 private:
  struct Change {
    std::int64_t seq = 0;
    KdNodeRecord node;  // its tree and node only, for a deletion
    bool deleted = false;
  };
  void add(std::int64_t seq, const KdNodeRecord& node, bool deleted);

  // tree -> block (node / kBlockNodes) -> changes in arrival order
  std::map<int, std::unordered_map<std::int64_t, std::vector<Change>>> blocks_;
  std::deque<std::int64_t> needed_;  // pending changes held by journal row needed_first_ + i
  std::int64_t needed_first_ = 0;
  std::int64_t cursor_ = 0;  // the next slice's first block
  std::int64_t max_node_ = 0;
};

}  // namespace placedb::storage::detail
