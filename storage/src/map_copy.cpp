// copyMap: every table of one map into another, whatever their backends.
#include "placedb/storage/map_copy.h"

#include "placedb/storage/map_store.h"
#include "row_checksums.h"

namespace placedb::storage {

std::string TableColumns::columnList() const {
  std::string out;
  for (const auto& c : columns) out += (out.empty() ? "" : ", ") + c;
  return out;
}

std::string TableColumns::selectInKeyOrder() const {
  std::string order;
  for (int i = 0; i < key_columns; ++i) order += (i ? ", " : "") + columns[i];
  return "SELECT " + columnList() + " FROM " + table + " ORDER BY " + order;
}

const std::vector<TableColumns>& mapTables() {
  // Parents before children for the keys checked at once (word_refs -> words, links and
  // hypotheses -> locations); frames, locations and words refer to each other through
  // deferred keys, checked at commit.
  static const std::vector<TableColumns> kTables = {
      {"sessions",
       {"id", "started_at", "ended_at", "clean_close", "software_version", "source",
        "source_digest", "settings_digest"}},
      {"settings", {"session_id", "key", "value"}, 2},
      {"vocabulary_imports",
       {"id", "session_id", "file", "checksum", "word_count", "mode", "imported_at", "extractor",
        "distance_unit", "settings"}},
      {"frames",
       {"id",
        "session_id",
        "source_index",
        "source_path",
        "outcome",
        "location_id",
        "features_ms",
        "quantisation_ms",
        "likelihood_ms",
        "filter_ms",
        "memory_ms",
        "storage_ms",
        "total_ms",
        "feature_count",
        "words_created",
        "vocabulary_size",
        "wm_size",
        "stm_size",
        "mean_quantisation_error",
        "stamp_ns"}},
      {"locations",
       {"id", "session_id", "weight", "tier", "created_frame", "held", "refs_digest", "checksum",
        "link_count"}},
      {"location_frames", {"location_id", "frame_id"}, 2},
      {"words",
       {"id", "created_frame", "vocabulary_import_id", "descriptor_type", "dim", "descriptor",
        "source_frame", "checksum"}},
      {"word_refs",
       {"location_id", "ordinal", "word_id", "x", "y", "size", "angle", "response"},
       2},
      {"links", {"location_a", "location_b", "type", "score"}, 3},
      {"hypotheses",
       {"frame_id", "best_location_id", "posterior", "loop_probability", "accepted",
        "rejected_reason", "pose_qw", "pose_qx", "pose_qy", "pose_qz", "pose_tx", "pose_ty",
        "pose_tz", "pose_inliers"}},
      {"engine_state", {"key", "value", "checksum"}},
      {"filter_posterior", {"location_id", "probability", "checksum"}},
      {"kd_nodes",
       {"tree", "node", "left_child", "right_child", "split_dim", "split_value", "checksum"},
       2},
      {"place_codes", {"location_id", "code", "checksum"}},
      {"location_word_descriptors", {"location_id", "dim", "words", "checksum"}},
      {"wm_entries", {"location_id", "wm_age", "checksum"}},
      // Fleet maps (schema 11): the id allocator and the side sessions' own memory.
      {"id_blocks", {"kind", "next"}},
      {"session_state", {"session_id", "key", "value", "checksum"}, 2},
      {"session_kd_nodes",
       {"session_id", "tree", "node", "left_child", "right_child", "split_dim", "split_value",
        "checksum"},
       3},
      {"session_posterior", {"session_id", "location_id", "probability"}, 2},
      {"session_memory", {"session_id", "location_id", "tier", "wm_age"}, 2},
  };
  return kTables;
}

namespace {

// Rows a statement of the destination writes: a server statement takes at most 65,535
// parameters.
constexpr std::size_t kBatch = 2000;

CellValue integer(std::int64_t v) {
  CellValue c;
  c.kind = CellValue::Kind::kInteger;
  c.integer = v;
  return c;
}

// A table's rows as the copy writes them. kd_nodes is the source's forest as its store reads it:
// a file's kd_nodes with its journal applied (schema 20), so the copy's is the whole forest.
void readRows(const MapStore& from, const TableColumns& t,
              const std::function<void(const TableRow&)>& row) {
  if (t.table != "kd_nodes") return from.readTable(t, row);
  for (const KdNodeRecord& n : from.loadKdNodes()) {
    CellValue value;
    value.kind = CellValue::Kind::kReal;
    value.real = n.split_value;
    row({integer(n.tree), integer(n.node), integer(n.left_child), integer(n.right_child),
         integer(n.split_dim), value,
         integer(detail::kdNodeChecksum(n.tree, n.node, n.left_child, n.right_child, n.split_dim,
                                        n.split_value))});
  }
}

}  // namespace

void copyMap(const MapStore& from, MapStore& to,
             const std::function<void(const CopyProgress&)>& progress) {
  if (to.readOnly())
    throw StorageError(ErrorCode::kReadOnly, "map " + to.path() + " is open read-only");
  if (!to.sessions().empty() || to.frameCount() > 0 || to.wordCount() > 0)
    throw StorageError(ErrorCode::kInvalidArgument,
                       "map " + to.path() + " is not empty: a copy is refused over another map");
  // Snapshot of the source, one transaction in the destination: a copy is whole or absent.
  const ReadSnapshot snapshot = from.readSnapshot();
  Transaction tx = to.begin();
  for (const TableColumns& t : mapTables()) {
    // A new map holds its own resume state rows (the kd_nodes row count): the copy's count
    // replaces the source's, which a file's journal may leave behind its forest.
    if (t.table == "engine_state") to.deleteState(detail::kKdNodeRowsKey);
    std::vector<TableRow> batch;
    std::int64_t rows = 0;
    readRows(from, t, [&](const TableRow& row) {
      batch.push_back(row);
      if (batch.size() == kBatch) {
        to.writeRows(t, batch);
        rows += static_cast<std::int64_t>(batch.size());
        batch.clear();
        if (progress) progress({t.table, rows});
      }
    });
    if (!batch.empty()) to.writeRows(t, batch);
    rows += static_cast<std::int64_t>(batch.size());
    if (t.table == "kd_nodes") to.putState(detail::kKdNodeRowsKey, std::to_string(rows));
    if (progress) progress({t.table, rows});
  }
  tx.commit();
}

}  // namespace placedb::storage
