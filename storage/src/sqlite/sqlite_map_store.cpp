// SqliteMapStore: opening, sessions, frames and locations.
#include "placedb/storage/sqlite_map_store.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "placedb/storage/map_files.h"
#include "placedb/storage/migrations.h"
#include "row_checksums.h"
#include "sqlite/database.h"
#include "sqlite/kd_node_journal.h"
#include "sqlite/map_file_check.h"
#include "sqlite/migrations_apply.h"
#include "sqlite/sqlite_checksums.h"
#include "sqlite/sqlite_location_rows.h"
#include "sqlite/wal_checkpointer.h"

namespace placedb::storage {
namespace {

constexpr const char* kNow = "strftime('%Y-%m-%dT%H:%M:%fZ', 'now')";

// The writer's advisory lock lives on a separate "<map>-lock" file: locking the map file itself
// would need an extra descriptor on it, and closing that descriptor drops the POSIX locks SQLite
// holds on the map for other connections of this process.
int acquireWriterLock(const std::string& path) {
  const std::string lock_path = lockFile(path);
  const int fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) {
    const int error = errno;
    const ErrorCode code = (error == EACCES || error == EROFS || error == EPERM)
                               ? ErrorCode::kReadOnly
                               : ErrorCode::kIo;
    throw StorageError(code, "cannot open map " + path + " for writing: cannot create " +
                                 lock_path + ": " + std::strerror(error));
  }
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int error = errno;
    ::close(fd);
    if (error == EWOULDBLOCK) {
      throw StorageError(ErrorCode::kMapBusy,
                         "map " + path + " is busy: another placedb writer has it open");
    }
    throw StorageError(ErrorCode::kIo, "cannot lock " + lock_path + ": " + std::strerror(error));
  }
  return fd;
}

FrameRecord readFrame(const detail::Statement& s) {
  FrameRecord f;
  f.id = s.columnInt(0);
  f.session_id = s.columnInt(1);
  f.source_index = s.columnInt(2);
  f.source_path = s.columnText(3);
  f.outcome = static_cast<FrameOutcome>(s.columnInt(4));
  f.location_id = s.columnOptionalInt(5);
  f.timings = {s.columnDouble(6),  s.columnDouble(7),  s.columnDouble(8), s.columnDouble(9),
               s.columnDouble(10), s.columnDouble(11), s.columnDouble(12)};
  f.stats = {s.columnInt(13), s.columnInt(14), s.columnInt(15),
             s.columnInt(16), s.columnInt(17), s.columnDouble(18)};
  f.stamp_ns = s.columnOptionalInt(19);
  return f;
}

constexpr const char* kFrameColumns =
    "id, session_id, source_index, source_path, outcome, location_id, features_ms, "
    "quantisation_ms, likelihood_ms, filter_ms, memory_ms, storage_ms, total_ms, feature_count, "
    "words_created, vocabulary_size, wm_size, stm_size, mean_quantisation_error, stamp_ns";

SessionRecord readSession(const detail::Statement& s) {
  SessionRecord r;
  r.id = s.columnInt(0);
  r.started_at = s.columnText(1);
  if (!s.isNull(2)) r.ended_at = s.columnText(2);
  r.clean_close = s.columnInt(3) != 0;
  r.software_version = s.columnText(4);
  r.source = s.columnText(5);
  if (!s.isNull(6)) r.source_digest = s.columnText(6);
  return r;
}

}  // namespace

// ---- Opening ----

SqliteMapStore::SqliteMapStore(const std::string& given_path, OpenMode mode,
                               const OpenOptions& options)
    : path_(given_path), read_only_(mode == OpenMode::kReadOnly) {
  const int current = currentSchemaVersion();
  const std::string path = detail::resolveMapPath(given_path);
  const detail::FileState state = detail::checkRawFile(path);
  if (read_only_) {
    if (state == detail::FileState::kMissing) {
      throw StorageError(ErrorCode::kIo, "map " + path + " not found");
    }
    if (state == detail::FileState::kEmpty) {
      throw StorageError(ErrorCode::kMapRefused, "map " + path + " refused: empty file");
    }
    const detail::MapIdentity identity = detail::inspectIdentity(path);
    const auto verdict = detail::judgeIdentity(identity, path, current);
    if (verdict == detail::Verdict::kBlankSqlite) {
      throw StorageError(ErrorCode::kMapRefused,
                         "map " + path + " refused: an empty SQLite database, not a placedb map");
    }
    if (verdict == detail::Verdict::kNeedsMigration) {
      throw StorageError(ErrorCode::kMapRefused, "map " + path + " refused: schema version " +
                                                     std::to_string(identity.user_version) +
                                                     " is older than this binary's " +
                                                     std::to_string(current) +
                                                     "; open it read-write once to upgrade it");
    }
    db_ = detail::openReadOnly(path);
    sqlite3_busy_timeout(db_->handle(), options.busy_timeout_ms);
    detail::checkSchemaObjects(*db_, path, current);
    if (options.check_references) {
      std::error_code size_error;
      const auto bytes = std::filesystem::file_size(path, size_error);
      if (options.integrity_check_max_bytes <= 0 ||
          (!size_error && std::int64_t(bytes) <= options.integrity_check_max_bytes)) {
        db_->queryInt("PRAGMA mmap_size = " + std::to_string(options.integrity_check_max_bytes));
        checkRowsAgree(path);
        db_->queryInt("PRAGMA mmap_size = 0");
      }
    }
    return;
  }

  bool check_pages = false;
  if (state == detail::FileState::kSqlite) {
    // Judge through a read-only connection first, so a refused file is never written to: its
    // identity here, every page below (a write can spread damage that no read of this session
    // would have met).
    auto reader = detail::openForInspection(path);
    const detail::MapIdentity identity = detail::readIdentity(*reader, path);
    const auto verdict = detail::judgeIdentity(identity, path, current);
    std::error_code size_error;
    const auto bytes = std::filesystem::file_size(path, size_error);
    const bool small_enough =
        options.integrity_check_max_bytes <= 0 ||
        (!size_error && std::int64_t(bytes) <= options.integrity_check_max_bytes);
    check_pages = verdict != detail::Verdict::kBlankSqlite && small_enough;
    // An older map's tables must be its version's too: an upgrade of other tables would fail
    // halfway (a user_version changed by hand).
    if (verdict != detail::Verdict::kBlankSqlite)
      detail::checkSchemaObjects(*reader, path, identity.user_version);
  }
  lock_fd_ = acquireWriterLock(path);
  try {
    db_ = std::make_unique<detail::Database>(path, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
    if (sqlite3_db_readonly(db_->handle(), "main") == 1) {
      throw StorageError(ErrorCode::kReadOnly,
                         "map " + path + " is read-only; open it with OpenMode::kReadOnly");
    }
    sqlite3_busy_timeout(db_->handle(), options.busy_timeout_ms);
    // On this connection, before its first write: SQLite verifies CHECK constraints in
    // quick_check only on a connection that could write (a tier of 7 passes a read-only one).
    if (check_pages) {
      // Read through a memory map while every page is read: half the time of read() copies.
      db_->queryInt("PRAGMA mmap_size = " + std::to_string(options.integrity_check_max_bytes));
      detail::checkIntegrity(*db_, path);
      checkRowsAgree(path);
      db_->queryInt("PRAGMA mmap_size = 0");
    }
    if (options.max_page_count > 0) {
      db_->queryInt("PRAGMA max_page_count = " + std::to_string(options.max_page_count));
    }
    if (db_->queryText("PRAGMA journal_mode = WAL") != "wal") {
      throw StorageError(ErrorCode::kStorage, "map " + path + ": cannot switch to WAL mode");
    }
    db_->exec("PRAGMA synchronous = NORMAL");
    // 32 MB of page cache: the word index is updated at random places every frame.
    db_->exec("PRAGMA cache_size = -32768");
    if (schemaVersion() < current) detail::applyMigrations(*db_, current);
    detail::checkSchemaObjects(*db_, path, current);
    db_->exec("PRAGMA foreign_keys = ON");
    checkpointer_ = std::make_unique<detail::WalCheckpointer>(db_->handle(), path);
    kd_pending_ = std::make_unique<detail::PendingKdNodes>();
  } catch (...) {
    checkpointer_.reset();
    db_.reset();
    ::close(lock_fd_);
    throw;
  }
}

SqliteMapStore::~SqliteMapStore() {
  foldKdNodeJournalAtClose();
  checkpointer_.reset();
  db_.reset();  // the last connection checkpoints and removes the -wal file
  if (lock_fd_ >= 0) ::close(lock_fd_);
}

int SqliteMapStore::schemaVersion() const {
  return static_cast<int>(db_->queryInt("PRAGMA user_version"));
}

void SqliteMapStore::requireWritable() const {
  if (read_only_) {
    throw StorageError(ErrorCode::kReadOnly, "map " + path_ + " is open read-only");
  }
}

ReadSnapshot SqliteMapStore::readSnapshot() const { return ReadSnapshot(db_.get()); }

Transaction SqliteMapStore::begin() {
  requireWritable();
  return Transaction(db_.get());
}

detail::WriteScope SqliteMapStore::writeScope() {
  requireWritable();
  return detail::WriteScope(*db_);
}

// ---- Sessions ----

std::int64_t SqliteMapStore::beginSession(const std::string& source,
                                          const std::map<std::string, std::string>& settings,
                                          const std::string& software_version) {
  auto scope = writeScope();
  static const std::string insert_session =
      std::string("INSERT INTO sessions (started_at, software_version, source) VALUES (") + kNow +
      ", ?1, ?2)";
  {
    auto s = db_->cached(insert_session.c_str());
    s->bind(1, software_version);
    s->bind(2, source);
    s->run();
  }
  const std::int64_t session_id = sqlite3_last_insert_rowid(db_->handle());
  auto s = db_->cached("INSERT INTO settings (session_id, key, value) VALUES (?1, ?2, ?3)");
  for (const auto& [key, value] : settings) {
    s->bind(1, session_id);
    s->bind(2, key);
    s->bind(3, value);
    s->run();
  }
  auto digest = db_->cached("UPDATE sessions SET settings_digest = ?2 WHERE id = ?1");
  digest->bind(1, session_id);
  digest->bind(2, std::int64_t{detail::settingsDigest(session_id, source, settings)});
  digest->run();
  scope.commit();
  return session_id;
}

void SqliteMapStore::setSourceDigest(std::int64_t session_id, const std::string& digest) {
  auto scope = writeScope();
  auto s = db_->cached("UPDATE sessions SET source_digest = ?2 WHERE id = ?1");
  s->bind(1, session_id);
  s->bind(2, digest);
  s->run();
  scope.commit();
}

void SqliteMapStore::endSession(std::int64_t session_id, bool clean) {
  auto scope = writeScope();
  static const std::string update =
      std::string("UPDATE sessions SET ended_at = ") + kNow + ", clean_close = ?2 WHERE id = ?1";
  auto s = db_->cached(update.c_str());
  s->bind(1, session_id);
  s->bind(2, std::int64_t{clean ? 1 : 0});
  s->run();
  if (sqlite3_changes(db_->handle()) != 1) {
    throw StorageError(ErrorCode::kInvalidArgument, "no session " + std::to_string(session_id));
  }
  if (clean) foldWholeKdNodeJournal();
  scope.commit();
}

void SqliteMapStore::reopenSession(std::int64_t session_id) {
  auto scope = writeScope();
  auto s = db_->cached("UPDATE sessions SET ended_at = NULL, clean_close = 0 WHERE id = ?1");
  s->bind(1, session_id);
  s->run();
  if (sqlite3_changes(db_->handle()) != 1) {
    throw StorageError(ErrorCode::kInvalidArgument, "no session " + std::to_string(session_id));
  }
  scope.commit();
}

std::vector<SessionRecord> SqliteMapStore::sessions() const {
  auto s = db_->cached(
      "SELECT id, started_at, ended_at, clean_close, software_version, source, source_digest "
      "FROM sessions "
      "ORDER BY id");
  std::vector<SessionRecord> result;
  while (s->step()) result.push_back(readSession(*s));
  return result;
}

std::optional<SessionRecord> SqliteMapStore::lastSession() const {
  auto s = db_->cached(
      "SELECT id, started_at, ended_at, clean_close, software_version, source, source_digest "
      "FROM sessions "
      "ORDER BY id DESC LIMIT 1");
  if (!s->step()) return std::nullopt;
  return readSession(*s);
}

std::map<std::string, std::string> SqliteMapStore::settings(std::int64_t session_id) const {
  auto s = db_->cached("SELECT key, value FROM settings WHERE session_id = ?1");
  s->bind(1, session_id);
  std::map<std::string, std::string> result;
  while (s->step()) result[s->columnText(0)] = s->columnText(1);
  // A setting deleted would resume the session with its default, one added with another value.
  auto digest = db_->cached("SELECT source, settings_digest FROM sessions WHERE id = ?1");
  digest->bind(1, session_id);
  if (digest->step() &&
      !detail::checksumMatches(*digest, 1,
                               detail::settingsDigest(session_id, digest->columnText(0), result)))
    detail::refuseDamagedRow(path_, "settings", "of session " + std::to_string(session_id),
                             "do not match the session's settings_digest (a setting was deleted, "
                             "added or changed, or the session's source)");
  return result;
}

// ---- Frames ----

std::int64_t SqliteMapStore::insertFrame(const FrameRecord& f) {
  auto scope = writeScope();
  static const std::string insert = std::string("INSERT INTO frames (") + kFrameColumns +
                                    ") VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, "
                                    "?13, ?14, ?15, ?16, ?17, ?18, ?19, ?20)";
  auto s = db_->cached(insert.c_str());
  if (f.id != 0) s->bind(1, f.id);
  s->bind(2, f.session_id);
  s->bind(3, f.source_index);
  s->bind(4, f.source_path);
  s->bind(5, std::int64_t{static_cast<int>(f.outcome)});
  s->bind(6, f.location_id);
  const FrameTimings& t = f.timings;
  int index = 7;
  for (double ms : {t.features_ms, t.quantisation_ms, t.likelihood_ms, t.filter_ms, t.memory_ms,
                    t.storage_ms, t.total_ms}) {
    s->bind(index++, ms);
  }
  const FrameStats& st = f.stats;
  for (std::int64_t value :
       {st.feature_count, st.words_created, st.vocabulary_size, st.wm_size, st.stm_size}) {
    s->bind(index++, value);
  }
  s->bind(index, st.mean_quantisation_error);
  s->bind(20, f.stamp_ns);
  s->run();
  const std::int64_t id = sqlite3_last_insert_rowid(db_->handle());
  scope.commit();
  return id;
}

std::optional<FrameRecord> SqliteMapStore::frame(std::int64_t frame_id) const {
  static const std::string select =
      std::string("SELECT ") + kFrameColumns + " FROM frames WHERE id = ?1";
  auto s = db_->cached(select.c_str());
  s->bind(1, frame_id);
  if (!s->step()) return std::nullopt;
  return readFrame(*s);
}

std::vector<FrameRecord> SqliteMapStore::frames(std::int64_t session_id) const {
  static const std::string select = std::string("SELECT ") + kFrameColumns +
                                    " FROM frames WHERE session_id = ?1 ORDER BY source_index";
  auto s = db_->cached(select.c_str());
  s->bind(1, session_id);
  std::vector<FrameRecord> result;
  while (s->step()) result.push_back(readFrame(*s));
  return result;
}

std::optional<std::int64_t> SqliteMapStore::lastFrameIndex(std::int64_t session_id) const {
  auto s = db_->cached("SELECT max(source_index) FROM frames WHERE session_id = ?1");
  s->bind(1, session_id);
  s->step();
  return s->columnOptionalInt(0);
}

std::int64_t SqliteMapStore::frameCount() const {
  auto s = db_->cached("SELECT count(*) FROM frames");
  s->step();
  return s->columnInt(0);
}

std::int64_t SqliteMapStore::frameCount(std::int64_t session_id) const {
  auto s = db_->cached("SELECT count(*) FROM frames WHERE session_id = ?1");
  s->bind(1, session_id);
  s->step();
  return s->columnInt(0);
}

std::int64_t SqliteMapStore::frameCount(FrameOutcome outcome) const {
  auto s = db_->cached("SELECT count(*) FROM frames WHERE outcome = ?1");
  s->bind(1, static_cast<std::int64_t>(outcome));
  s->step();
  return s->columnInt(0);
}

std::optional<FrameRecord> SqliteMapStore::lastFrame() const {
  static const std::string select =
      std::string("SELECT ") + kFrameColumns + " FROM frames ORDER BY id DESC LIMIT 1";
  auto s = db_->cached(select.c_str());
  if (!s->step()) return std::nullopt;
  return readFrame(*s);
}

// ---- Locations ----

void SqliteMapStore::insertLocation(const LocationRecord& l) {
  auto scope = writeScope();
  // It holds no other row yet: each is marked as it is written (location_rows.h).
  auto s = db_->cached(
      "INSERT INTO locations (id, session_id, weight, tier, created_frame, held, refs_digest, "
      "checksum, link_count) VALUES (?1, ?2, ?3, ?4, ?5, 0, ?6, ?7, 0)");
  s->bind(1, l.id);
  s->bind(2, l.session_id);
  s->bind(3, l.weight);
  s->bind(4, std::int64_t{static_cast<int>(l.tier)});
  s->bind(5, l.created_frame);
  s->bind(6, std::int64_t{detail::refsDigest(l.id, {})});
  s->bind(7, std::int64_t{detail::locationChecksum(l.id, l.session_id, l.weight, l.created_frame)});
  s->run();
  scope.commit();
}

void SqliteMapStore::updateWeight(std::int64_t location_id, std::int64_t weight) {
  auto scope = writeScope();
  auto s = db_->cached(
      "UPDATE locations SET weight = ?2 WHERE id = ?1 RETURNING session_id, created_frame");
  s->bind(1, location_id);
  s->bind(2, weight);
  if (!s->step())
    throw StorageError(ErrorCode::kInvalidArgument, "no location " + std::to_string(location_id));
  const std::uint32_t sum =
      detail::locationChecksum(location_id, s->columnInt(0), weight, s->columnOptionalInt(1));
  s->reset();
  auto sum_update = db_->cached("UPDATE locations SET checksum = ?2 WHERE id = ?1");
  sum_update->bind(1, location_id);
  sum_update->bind(2, std::int64_t{sum});
  sum_update->run();
  scope.commit();
}

void SqliteMapStore::setTier(const std::vector<std::int64_t>& location_ids, Tier tier) {
  auto scope = writeScope();
  auto s = db_->cached("UPDATE locations SET tier = ?2 WHERE id = ?1");
  for (std::int64_t id : location_ids) {
    s->bind(1, id);
    s->bind(2, std::int64_t{static_cast<int>(tier)});
    s->run();
  }
  scope.commit();
}

void SqliteMapStore::deleteLocation(std::int64_t location_id) {
  auto scope = writeScope();
  {
    auto s = db_->cached("DELETE FROM filter_posterior WHERE location_id = ?1");
    s->bind(1, location_id);
    s->run();
  }
  {
    auto s = db_->cached("DELETE FROM engine_state WHERE key IN (?1, ?2)");
    s->bind(1, locationKeypointsKey(location_id));
    s->bind(2, locationLatestViewKey(location_id));
    s->run();
  }
  {
    // Its links go with it (ON DELETE CASCADE): the locations at their other ends count one less.
    auto s = db_->cached(
        "UPDATE locations SET link_count = link_count - (SELECT count(*) FROM links k WHERE "
        "(k.location_a = ?1 AND k.location_b = locations.id) OR (k.location_b = ?1 AND "
        "k.location_a = locations.id)) WHERE id IN (SELECT location_b FROM links WHERE "
        "location_a = ?1 UNION SELECT location_a FROM links WHERE location_b = ?1)");
    s->bind(1, location_id);
    s->run();
  }
  auto s = db_->cached("DELETE FROM locations WHERE id = ?1");
  s->bind(1, location_id);
  s->run();
  scope.commit();
}

void SqliteMapStore::markHeld(std::int64_t location_id, std::int64_t bit, bool held) {
  // Unchanged rows are not written again (a location brought back keeps its WM age bit).
  auto s =
      db_->cached(held ? "UPDATE locations SET held = held | ?2 WHERE id = ?1 AND held & ?2 = 0"
                       : "UPDATE locations SET held = held & ~?2 WHERE id = ?1 AND held & ?2 != 0");
  s->bind(1, location_id);
  s->bind(2, bit);
  s->run();
}

void SqliteMapStore::checkRowsAgree(const std::string& path) const {
  detail::checkForeignKeys(*db_, path);
  if (schemaVersion() < detail::kLocationRowsSchemaVersion) return;  // recorded when upgraded
  const auto refuse = [&path](CheckFinding f) {
    detail::refuseDamagedRow(path, f.table, f.row, f.problem);
  };
  detail::checkRowSums(*db_, path);
  detail::checkLocationRefs(*db_, refuse);
  detail::checkLinkCounts(*db_, refuse);
  detail::checkFrameRows(*db_, refuse);
}

void SqliteMapStore::checkStoredRows() const {
  const auto refuse = [this](CheckFinding f) {
    detail::refuseDamagedRow(path_, f.table, f.row, f.problem);
  };
  detail::checkSessionRows(*db_, refuse);
  detail::checkLocationRows(*db_, refuse);
}

void SqliteMapStore::addCoveredFrame(std::int64_t location_id, std::int64_t frame_id) {
  auto scope = writeScope();
  auto s =
      db_->cached("INSERT OR IGNORE INTO location_frames (location_id, frame_id) VALUES (?1, ?2)");
  s->bind(1, location_id);
  s->bind(2, frame_id);
  s->run();
  scope.commit();
}

std::vector<std::int64_t> SqliteMapStore::coveredFrames(std::int64_t location_id) const {
  auto s =
      db_->cached("SELECT frame_id FROM location_frames WHERE location_id = ?1 ORDER BY frame_id");
  s->bind(1, location_id);
  std::vector<std::int64_t> result;
  while (s->step()) result.push_back(s->columnInt(0));
  return result;
}

std::map<std::int64_t, std::vector<std::int64_t>> SqliteMapStore::coveredFrames(
    const std::vector<std::int64_t>& location_ids) const {
  std::map<std::int64_t, std::vector<std::int64_t>> result;
  for (std::int64_t id : location_ids) result[id] = coveredFrames(id);
  return result;
}

std::vector<LocationWeight> SqliteMapStore::locationsInTier(Tier tier) const {
  auto s = db_->cached("SELECT id, weight FROM locations WHERE tier = ?1 ORDER BY id");
  s->bind(1, std::int64_t{static_cast<int>(tier)});
  std::vector<LocationWeight> result;
  while (s->step()) result.push_back({s->columnInt(0), s->columnInt(1)});
  return result;
}

std::optional<LocationRecord> SqliteMapStore::location(std::int64_t location_id) const {
  auto s = db_->cached(
      "SELECT id, session_id, weight, tier, created_frame FROM locations WHERE id = ?1");
  s->bind(1, location_id);
  if (!s->step()) return std::nullopt;
  return LocationRecord{s->columnInt(0), s->columnInt(1), s->columnInt(2),
                        static_cast<Tier>(s->columnInt(3)), s->columnOptionalInt(4)};
}

std::int64_t SqliteMapStore::acceptedClosureCount(bool posed) const {
  auto s = db_->cached(posed ? "SELECT count(*) FROM v_loop_closure_poses"
                             : "SELECT count(*) FROM hypotheses WHERE accepted = 1");
  s->step();
  return s->columnInt(0);
}

std::int64_t SqliteMapStore::linkCount(LinkType type) const {
  auto s = db_->cached("SELECT count(*) FROM links WHERE type = ?1");
  s->bind(1, static_cast<std::int64_t>(type));
  s->step();
  return s->columnInt(0);
}

std::int64_t SqliteMapStore::locationCount() const {
  auto s = db_->cached("SELECT count(*) FROM locations");
  s->step();
  return s->columnInt(0);
}

}  // namespace placedb::storage
