// MapStore: what the engine keeps to resume exactly (engine state, kd-forest nodes, the
// filter's posterior) and the vocabulary files imported into the map.
#include <nlohmann/json.hpp>

#include "placedb/storage/sqlite_map_store.h"
#include "sqlite/database.h"
#include "sqlite/kd_node_journal.h"
#include "sqlite/sqlite_checksums.h"
#include "sqlite/sqlite_location_rows.h"
#include "sqlite/sqlite_rows.h"

namespace placedb::storage {

// ---- Engine state ----

void SqliteMapStore::putState(const std::string& key, const std::vector<std::uint8_t>& value) {
  auto scope = writeScope();
  auto s = db_->cached(
      "INSERT INTO engine_state (key, value, checksum) VALUES (?1, ?2, ?3) "
      "ON CONFLICT (key) DO UPDATE SET value = excluded.value, checksum = excluded.checksum");
  s->bind(1, key);
  s->bindBlob(2, value.data(), value.size());
  s->bind(3, std::int64_t{detail::stateChecksum(key, value.data(), value.size())});
  s->run();
  if (const auto location = locationOfKeypointsKey(key))
    markHeld(*location, detail::kHeldKeypoints, true);
  scope.commit();
}

void SqliteMapStore::putState(const std::string& key, const std::string& value) {
  auto scope = writeScope();
  auto s = db_->cached(
      "INSERT INTO engine_state (key, value, checksum) VALUES (?1, ?2, ?3) "
      "ON CONFLICT (key) DO UPDATE SET value = excluded.value, checksum = excluded.checksum");
  s->bind(1, key);
  s->bind(2, value);
  s->bind(3, std::int64_t{detail::stateChecksum(key, value.data(), value.size())});
  s->run();
  scope.commit();
}

std::optional<std::vector<std::uint8_t>> SqliteMapStore::getState(const std::string& key) const {
  auto s = db_->cached("SELECT value, checksum FROM engine_state WHERE key = ?1");
  s->bind(1, key);
  if (!s->step()) return std::nullopt;
  std::vector<std::uint8_t> value = s->columnBlob(0);
  if (!detail::checksumMatches(*s, 1, detail::stateChecksum(key, value.data(), value.size())))
    detail::refuseDamagedRow(path_, "engine_state", "'" + key + "'", "fails its checksum");
  return value;
}

std::optional<std::string> SqliteMapStore::getStateText(const std::string& key) const {
  auto s = db_->cached("SELECT value, checksum FROM engine_state WHERE key = ?1");
  s->bind(1, key);
  if (!s->step()) return std::nullopt;
  std::string value = s->columnText(0);
  if (!detail::checksumMatches(*s, 1, detail::stateChecksum(key, value.data(), value.size())))
    detail::refuseDamagedRow(path_, "engine_state", "'" + key + "'", "fails its checksum");
  return value;
}

void SqliteMapStore::deleteState(const std::string& key) {
  auto scope = writeScope();
  auto s = db_->cached("DELETE FROM engine_state WHERE key = ?1");
  s->bind(1, key);
  s->run();
  if (const auto location = locationOfKeypointsKey(key))
    markHeld(*location, detail::kHeldKeypoints, false);
  scope.commit();
}

std::int64_t SqliteMapStore::storedKdNodeRows() const {
  const auto text = getStateText(detail::kKdNodeRowsKey);
  if (!text) detail::refuseDamagedRow(path_, "engine_state", detail::kKdNodeRowsKey, "is missing");
  try {
    std::size_t used = 0;
    const long long rows = std::stoll(*text, &used);
    if (used == text->size() && rows >= 0) return rows;
  } catch (const std::exception&) {
  }
  detail::refuseDamagedRow(path_, "engine_state", detail::kKdNodeRowsKey, "is not a row count");
}

namespace {

// Applies `changes` to kd_nodes in their order, keeping `rows` its row count: an upsert inserts
// where the node had no row (most are splits), else updates it, and a plain insert last makes a
// row neither could write fail as it should. The row count follows without a count(*).
void applyToKdNodes(detail::Database& db, const detail::KdNodeChanges& changes,
                    std::int64_t& rows) {
  if (!changes.deletions.empty()) {
    auto s = db.cached("DELETE FROM kd_nodes WHERE tree = ?1 AND node = ?2");
    for (const auto& [tree, node] : changes.deletions) {
      s->bind(1, std::int64_t(tree));
      s->bind(2, node);
      s->run();
      rows -= sqlite3_changes(db.handle());
    }
  }
  if (changes.upserts.empty()) return;
  auto add = db.cached(
      "INSERT OR IGNORE INTO kd_nodes (tree, node, left_child, right_child, split_dim, "
      "split_value, checksum) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)");
  auto update = db.cached(
      "UPDATE kd_nodes SET left_child = ?3, right_child = ?4, split_dim = ?5, split_value = ?6, "
      "checksum = ?7 WHERE tree = ?1 AND node = ?2");
  auto insert = db.cached(
      "INSERT INTO kd_nodes (tree, node, left_child, right_child, split_dim, split_value, "
      "checksum) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)");
  for (const KdNodeRecord& n : changes.upserts) {
    const std::int64_t sum = detail::kdNodeChecksum(n.tree, n.node, n.left_child, n.right_child,
                                                    n.split_dim, n.split_value);
    for (detail::Statement* s : {&*add, &*update, &*insert}) {
      s->bind(1, std::int64_t(n.tree));
      s->bind(2, n.node);
      s->bind(3, n.left_child);
      s->bind(4, n.right_child);
      s->bind(5, std::int64_t(n.split_dim));
      s->bind(6, n.split_value);
      s->bind(7, sum);
      s->run();
      const bool changed = sqlite3_changes(db.handle()) > 0;
      if (s != &*update && changed) ++rows;
      if (changed) break;
    }
  }
}

// Every kd_node_journal row in order; a row that fails its checksum or is not whole records
// refuses the map.
std::vector<std::pair<std::int64_t, detail::KdNodeChanges>> readKdNodeJournal(
    detail::Database& db, const std::string& path) {
  std::vector<std::pair<std::int64_t, detail::KdNodeChanges>> out;
  auto s = db.cached("SELECT seq, changes, checksum FROM kd_node_journal ORDER BY seq");
  while (s->step()) {
    detail::KdNodeChanges changes;
    if (const char* problem = detail::kdNodeJournalRowProblem(*s, &changes))
      detail::refuseDamagedRow(path, "kd_node_journal", std::to_string(s->columnInt(0)), problem);
    out.emplace_back(s->columnInt(0), std::move(changes));
  }
  return out;
}

}  // namespace

void SqliteMapStore::foldKdNodeJournal(std::int64_t& rows) {
  for (const auto& [seq, changes] : readKdNodeJournal(*db_, path_)) {
    applyToKdNodes(*db_, changes, rows);
    kd_journal_next_ = std::max(kd_journal_next_, seq + 1);
  }
  db_->cached("DELETE FROM kd_node_journal")->run();
  kd_pending_->clear();
  kd_journal_stale_ = false;
}

void SqliteMapStore::foldWholeKdNodeJournal() {
  auto scope = writeScope();
  if (db_->queryInt("SELECT count(*) FROM kd_node_journal") == 0) return;
  std::int64_t rows = storedKdNodeRows();
  foldKdNodeJournal(rows);
  putState(detail::kKdNodeRowsKey, std::to_string(rows));
  scope.commit();
}

void SqliteMapStore::foldKdNodeJournalAtClose() noexcept {
  // Should this fail, the journal stays and the next open reads it.
  if (read_only_ || !db_ || db_->inTransaction()) return;
  try {
    foldWholeKdNodeJournal();
  } catch (...) {
  }
}

void SqliteMapStore::writeKdNodes(const std::vector<KdNodeRecord>& upserts,
                                  const std::vector<std::pair<int, std::int64_t>>& deletions,
                                  bool replace_all) {
  auto scope = writeScope();
  if (db_->rollbacks() != kd_rollbacks_seen_) kd_journal_stale_ = true;
  std::int64_t rows = 0;
  if (replace_all) {
    db_->cached("DELETE FROM kd_nodes")->run();
    db_->cached("DELETE FROM kd_node_journal")->run();
    kd_pending_->clear();
    kd_journal_stale_ = false;
    applyToKdNodes(*db_, {{}, upserts}, rows);
  } else {
    rows = storedKdNodeRows();
    // The journal as committed is the truth: after an open or a rolled-back change, fold it all.
    if (kd_journal_stale_) foldKdNodeJournal(rows);
    const detail::KdNodeChanges changes{deletions, upserts};
    const std::int64_t seq = kd_journal_next_++;
    const std::vector<std::uint8_t> bytes = detail::packKdNodeChanges(changes);
    auto add =
        db_->cached("INSERT INTO kd_node_journal (seq, changes, checksum) VALUES (?1, ?2, ?3)");
    add->bind(1, seq);
    add->bindBlob(2, bytes.data(), bytes.size());
    add->bind(3, std::int64_t{detail::kdJournalChecksum(seq, bytes.data(), bytes.size())});
    add->run();
    kd_pending_->record(seq, changes);
    applyToKdNodes(*db_, kd_pending_->takeNextSlice(), rows);
    auto drop = db_->cached("DELETE FROM kd_node_journal WHERE seq < ?1");
    drop->bind(1, kd_pending_->oldestNeeded(kd_journal_next_));
    drop->run();
  }
  putState(detail::kKdNodeRowsKey, std::to_string(rows));
  scope.commit();
  kd_rollbacks_seen_ = db_->rollbacks();
}

std::vector<KdNodeRecord> SqliteMapStore::loadKdNodes() const {
  // One snapshot for the table and the journal: a writer beside a reader folds and drops rows.
  const ReadSnapshot snapshot(db_.get());
  std::vector<KdNodeRecord> nodes;
  auto s = db_->cached(
      "SELECT tree, node, left_child, right_child, split_dim, split_value, checksum FROM kd_nodes "
      "ORDER BY tree, node");
  while (s->step()) {
    KdNodeRecord n;
    n.tree = static_cast<int>(s->columnInt(0));
    n.node = s->columnInt(1);
    n.left_child = s->columnInt(2);
    n.right_child = s->columnInt(3);
    n.split_dim = static_cast<int>(s->columnInt(4));
    n.split_value = s->columnDouble(5);
    if (!detail::checksumMatches(
            *s, 6,
            detail::kdNodeChecksum(s->columnInt(0), n.node, n.left_child, n.right_child,
                                   s->columnInt(4), n.split_value)))
      detail::refuseDamagedRow(
          path_, "kd_nodes",
          "(tree " + std::to_string(s->columnInt(0)) + ", node " + std::to_string(n.node) + ")",
          "fails its checksum");
    nodes.push_back(n);
  }
  const std::int64_t stored = storedKdNodeRows();
  if (stored != static_cast<std::int64_t>(nodes.size()))
    throw StorageError(ErrorCode::kMapRefused,
                       "map " + path_ + " damaged: kd_nodes holds " + std::to_string(nodes.size()) +
                           " rows where the map recorded " + std::to_string(stored) +
                           " (rows were deleted or added); nothing was written");
  const auto journal = readKdNodeJournal(*db_, path_);
  if (journal.empty()) return nodes;  // a map closed cleanly
  std::map<detail::KdNodeKey, KdNodeRecord> forest;
  for (const KdNodeRecord& n : nodes)
    forest.emplace_hint(forest.end(), detail::KdNodeKey{n.tree, n.node}, n);
  for (const auto& [seq, changes] : journal) detail::applyKdNodeChanges(changes, &forest);
  nodes.clear();
  for (const auto& [key, n] : forest) nodes.push_back(n);
  return nodes;
}

void SqliteMapStore::putPosterior(const std::vector<std::pair<std::int64_t, double>>& posterior) {
  auto scope = writeScope();
  {
    auto s = db_->cached("DELETE FROM filter_posterior");
    s->run();
  }
  static const detail::RowInserts sql("INSERT",
                                      "filter_posterior (location_id, probability, checksum)", 3);
  detail::insertRows(*db_, sql, posterior.size(), [&](detail::Statement& s, int at, std::size_t i) {
    const auto& [location, probability] = posterior[i];
    s.bind(at + 1, location);
    s.bind(at + 2, probability);
    s.bind(at + 3, std::int64_t{detail::posteriorChecksum(location, probability)});
  });
  scope.commit();
}

std::vector<std::pair<std::int64_t, double>> SqliteMapStore::loadPosterior() const {
  auto s = db_->cached(
      "SELECT location_id, probability, checksum FROM filter_posterior ORDER BY location_id");
  std::vector<std::pair<std::int64_t, double>> result;
  while (s->step()) {
    const std::int64_t location = s->columnInt(0);
    if (!detail::checksumMatches(*s, 2, detail::posteriorChecksum(location, s->columnDouble(1))))
      detail::refuseDamagedRow(path_, "filter_posterior", std::to_string(location),
                               "fails its checksum");
    result.emplace_back(location, s->columnDouble(1));
  }
  return result;
}

// ---- Vocabulary imports ----

std::int64_t SqliteMapStore::recordVocabularyImport(const VocabularyImportRecord& v) {
  auto scope = writeScope();
  auto s = db_->cached(
      "INSERT INTO vocabulary_imports (session_id, file, checksum, word_count, mode, imported_at, "
      "extractor, distance_unit, settings) "
      "VALUES (?1, ?2, ?3, ?4, ?5, coalesce(?6, strftime('%Y-%m-%dT%H:%M:%fZ', 'now')), ?7, ?8, "
      "?9)");
  s->bind(1, v.session_id);
  s->bind(2, v.file);
  s->bind(3, v.checksum);
  s->bind(4, v.word_count);
  s->bind(5, std::string(v.mode == VocabularyMode::kFixed ? "fixed" : "seed"));
  if (!v.imported_at.empty()) s->bind(6, v.imported_at);
  s->bind(7, v.extractor);
  s->bind(8, v.distance_unit);
  s->bind(9, nlohmann::json(v.settings).dump());
  s->run();
  const std::int64_t id = sqlite3_last_insert_rowid(db_->handle());
  scope.commit();
  return id;
}

std::vector<VocabularyImportRecord> SqliteMapStore::vocabularyImports() const {
  auto s = db_->cached(
      "SELECT id, session_id, file, checksum, word_count, mode, imported_at, "
      "coalesce(extractor, ''), coalesce(distance_unit, ''), settings "
      "FROM vocabulary_imports ORDER BY id");
  std::vector<VocabularyImportRecord> result;
  while (s->step()) {
    VocabularyImportRecord v;
    v.id = s->columnInt(0);
    v.session_id = s->columnOptionalInt(1);
    v.file = s->columnText(2);
    v.checksum = s->columnText(3);
    v.word_count = s->columnInt(4);
    v.mode = s->columnText(5) == "fixed" ? VocabularyMode::kFixed : VocabularyMode::kSeed;
    v.imported_at = s->columnText(6);
    v.extractor = s->columnText(7);
    v.distance_unit = s->columnText(8);
    if (!s->isNull(9)) {
      const auto settings = nlohmann::json::parse(s->columnText(9), nullptr, false);
      if (!settings.is_object())
        throw StorageError(ErrorCode::kMapRefused, "map " + path_ + ": vocabulary import " +
                                                       std::to_string(v.id) +
                                                       " has damaged settings (not a JSON object)");
      for (const auto& [key, value] : settings.items())
        if (value.is_string()) v.settings[key] = value.get<std::string>();
    }
    result.push_back(std::move(v));
  }
  return result;
}

}  // namespace placedb::storage
