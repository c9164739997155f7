// PgMapStore: opening (identity, migrations, the writer's lock), sessions, frames and locations.
#include "postgres/pg_map_store.h"

#include <map>

#include "backends.h"
#include "location_rows.h"
#include "placedb/storage/migrations.h"
#include "row_checksums.h"

namespace placedb::storage {
namespace {

constexpr const char* kNowText =
    "to_char(clock_timestamp() AT TIME ZONE 'UTC', 'YYYY-MM-DD\"T\"HH24:MI:SS.MS\"Z\"')";

constexpr const char* kFrameColumns =
    "id, session_id, source_index, source_path, outcome, location_id, features_ms, "
    "quantisation_ms, likelihood_ms, filter_ms, memory_ms, storage_ms, total_ms, feature_count, "
    "words_created, vocabulary_size, wm_size, stm_size, mean_quantisation_error, stamp_ns";

FrameRecord readFrame(const detail::PgResult& r, int row) {
  FrameRecord f;
  f.id = r.integer(row, 0);
  f.session_id = r.integer(row, 1);
  f.source_index = r.integer(row, 2);
  f.source_path = r.text(row, 3);
  f.outcome = static_cast<FrameOutcome>(r.integer(row, 4));
  f.location_id = r.optionalInteger(row, 5);
  f.timings = {r.real(row, 6),  r.real(row, 7),  r.real(row, 8), r.real(row, 9),
               r.real(row, 10), r.real(row, 11), r.real(row, 12)};
  f.stats = {r.integer(row, 13), r.integer(row, 14), r.integer(row, 15),
             r.integer(row, 16), r.integer(row, 17), r.real(row, 18)};
  f.stamp_ns = r.optionalInteger(row, 19);
  return f;
}

SessionRecord readSession(const detail::PgResult& r, int row) {
  SessionRecord s;
  s.id = r.integer(row, 0);
  s.started_at = r.text(row, 1);
  if (!r.isNull(row, 2)) s.ended_at = r.text(row, 2);
  s.clean_close = r.integer(row, 3) != 0;
  s.software_version = r.text(row, 4);
  s.source = r.text(row, 5);
  if (!r.isNull(row, 6)) s.source_digest = r.text(row, 6);
  return s;
}

constexpr const char* kSessionColumns =
    "SELECT id, started_at, ended_at, clean_close, software_version, source, source_digest "
    "FROM sessions ";

}  // namespace

std::unique_ptr<MapStore> openPgMapStore(const std::string& uri, OpenMode mode,
                                         const OpenOptions& options) {
  return std::make_unique<PgMapStore>(uri, mode, options);
}

// ---- Opening ----

PgMapStore::PgMapStore(const std::string& uri, OpenMode mode, const OpenOptions& options)
    : label_(mapDisplayName(uri)), read_only_(mode == OpenMode::kReadOnly) {
  db_ = std::make_unique<detail::PgConnection>(uri, label_, options.connect_timeout_s);
  const bool has_meta = db_->queryInt(
                            "SELECT count(*) FROM pg_catalog.pg_tables WHERE schemaname = "
                            "current_schema() AND tablename = 'placedb_meta'") > 0;
  if (read_only_) {
    if (!has_meta)
      throw StorageError(ErrorCode::kIo, "map " + label_ +
                                             " not found: the "
                                             "database holds no placedb map");
    // Nothing this connection runs may write, whatever a caller does.
    db_->exec("SET SESSION CHARACTERISTICS AS TRANSACTION READ ONLY");
    const int version = schemaVersion();
    if (version > currentSchemaVersion())
      throw StorageError(ErrorCode::kMapRefused, "map " + label_ + " refused: schema version " +
                                                     std::to_string(version) +
                                                     " is newer than this binary's " +
                                                     std::to_string(currentSchemaVersion()));
    if (version < currentSchemaVersion())
      throw StorageError(ErrorCode::kMapRefused, "map " + label_ + " refused: schema version " +
                                                     std::to_string(version) +
                                                     " is older than this binary's " +
                                                     std::to_string(currentSchemaVersion()) +
                                                     "; open it read-write once to upgrade it");
    return;
  }
  // A hot standby (a read replica: in recovery) serves reads only. Said before any lock is
  // taken or write tried, in one line instead of the server's "read-only transaction".
  if (db_->queryInt("SELECT pg_is_in_recovery()::int") != 0)
    throw StorageError(ErrorCode::kReadOnly,
                       "map " + label_ +
                           " is on a hot standby (a read-only replica): it answers query, info, "
                           "export and report; map into (or write) its primary server");
  // Session-level: held until this connection closes, released by the server if the writer
  // dies, so a killed writer never leaves the map locked.
  if (!claimMainLine() && !options.side_writer)
    throw StorageError(ErrorCode::kMapBusy,
                       "map " + label_ + " is busy: another placedb writer has it open");
  // A commit returns before its WAL reaches the disk, as SQLite's synchronous=NORMAL does: a
  // crash of the writer loses nothing committed, a crash of the server may lose the last
  // commits (never consistency), and the next run resumes from the last frame kept. Waiting
  // for the flush would cost a disk sync per frame.
  db_->exec("SET synchronous_commit = off");
  migrate();
}

PgMapStore::~PgMapStore() {
  // Closing the connection would release the locks too, but the server does so only when the
  // backend has finished exiting: a writer that reopens the map at once could find it busy.
  try {
    const std::set<std::int64_t> sessions = claimed_;
    for (std::int64_t id : sessions) releaseSession(id);
    releaseMainLine();
  } catch (const std::exception&) {
    // A lost connection: the server releases them when it notices.
  }
}

void PgMapStore::migrate() {
  const int current = currentSchemaVersion();
  const auto& scripts = pgMigrations();
  db_->beginWrite();
  try {
    // Writers that open a map at once migrate it one after the other; each reads the version
    // the one before it left.
    db_->run("SELECT pg_advisory_xact_lock($1)", detail::PgParams().add(kMigrationKey));
    const bool has_meta = db_->queryInt(
                              "SELECT count(*) FROM pg_catalog.pg_tables WHERE schemaname = "
                              "current_schema() AND tablename = 'placedb_meta'") > 0;
    int found = 0;
    if (has_meta) {
      found = schemaVersion();
    } else if (db_->queryInt("SELECT count(*) FROM pg_catalog.pg_class c JOIN "
                             "pg_catalog.pg_namespace n ON n.oid = c.relnamespace WHERE "
                             "n.nspname = current_schema() AND c.relkind IN ('r', 'v')") > 0) {
      throw StorageError(
          ErrorCode::kMapRefused,
          "map " + label_ + " refused: the database holds other tables, not a placedb map");
    }
    if (found > current)
      throw StorageError(ErrorCode::kMapRefused,
                         "map " + label_ + " refused: schema version " + std::to_string(found) +
                             " is newer than this binary's " + std::to_string(current));
    for (const Migration& m : scripts) {
      if (m.version <= found) continue;
      db_->exec(m.sql);
      if (m.version == detail::kLocationRowsSchemaVersion && found > 0) fillLocationRows();
      db_->run(
          "INSERT INTO placedb_meta (key, value) VALUES ('schema_version', $1), "
          "('application_id', '1347175490') ON CONFLICT (key) DO UPDATE SET value = "
          "excluded.value",
          detail::PgParams().add(std::to_string(m.version)));
    }
    // Guards keyed to a former owner are keyed again by the owner's first writer (pg/0021); a
    // confined writer changes nothing.
    db_->run("SELECT placedb_key_guards()");
    refuseGuardsOfMissingRole();
    if (found == 0) {
      // A new map's forest has no nodes; the count is checked against the table when it loads
      // (SQLite's schema-8 migration writes the same row).
      const std::string zero = "0";
      db_->run("INSERT INTO engine_state (key, value, checksum) VALUES ($1, $2, $3)",
               detail::PgParams()
                   .add(std::string(detail::kKdNodeRowsKey))
                   .addBytes(zero.data(), zero.size())
                   .add(std::int64_t{
                       detail::stateChecksum(detail::kKdNodeRowsKey, zero.data(), zero.size())}));
    }
    db_->commit();
  } catch (...) {
    db_->rollbackQuietly();
    throw;
  }
}

void PgMapStore::fillLocationRows() {
  {
    const auto sessions = db_->run("SELECT id, source FROM sessions");
    std::vector<std::int64_t> ids, digests;
    for (int i = 0; i < sessions.rows(); ++i) {
      ids.push_back(sessions.integer(i, 0));
      std::map<std::string, std::string> settings;
      const auto r = db_->run("SELECT key, value FROM settings WHERE session_id = $1",
                              detail::PgParams().add(ids.back()));
      for (int k = 0; k < r.rows(); ++k) settings[r.text(k, 0)] = r.text(k, 1);
      digests.push_back(detail::settingsDigest(ids.back(), sessions.text(i, 1), settings));
    }
    db_->run(
        "UPDATE sessions s SET settings_digest = u.d FROM unnest($1::int8[], $2::int8[]) AS "
        "u(id, d) WHERE s.id = u.id",
        detail::PgParams().addArray(ids).addArray(digests));
  }
  for (const char* table : {"wm_entries", "filter_posterior"}) {
    const bool ages = std::string(table) == "wm_entries";
    const auto r = db_->run(
        (std::string("SELECT location_id, ") + (ages ? "wm_age" : "probability") + " FROM " + table)
            .c_str());
    std::vector<std::int64_t> ids, sums;
    for (int i = 0; i < r.rows(); ++i) {
      ids.push_back(r.integer(i, 0));
      sums.push_back(ages ? detail::wmEntryChecksum(ids.back(), r.integer(i, 1))
                          : detail::posteriorChecksum(ids.back(), r.real(i, 1)));
    }
    db_->run((std::string("UPDATE ") + table +
              " t SET checksum = u.s FROM unnest($1::int8[], $2::int8[]) AS u(id, s) "
              "WHERE t.location_id = u.id")
                 .c_str(),
             detail::PgParams().addArray(ids).addArray(sums));
  }
  {
    const auto r = db_->run("SELECT id, session_id, weight, created_frame FROM locations");
    std::vector<std::int64_t> ids, sums;
    for (int i = 0; i < r.rows(); ++i) {
      ids.push_back(r.integer(i, 0));
      sums.push_back(detail::locationChecksum(ids.back(), r.integer(i, 1), r.integer(i, 2),
                                              r.optionalInteger(i, 3)));
    }
    db_->run(
        "UPDATE locations l SET checksum = u.s FROM unnest($1::int8[], $2::int8[]) AS u(id, s) "
        "WHERE l.id = u.id",
        detail::PgParams().addArray(ids).addArray(sums));
  }
  db_->run(
      "UPDATE locations l SET link_count = (SELECT count(*) FROM links k WHERE k.location_a = "
      "l.id) + (SELECT count(*) FROM links k WHERE k.location_b = l.id)");
  db_->run(
      "UPDATE locations l SET held = "
      "(EXISTS (SELECT 1 FROM place_codes p WHERE p.location_id = l.id))::int * 1 + "
      "(EXISTS (SELECT 1 FROM location_word_descriptors d WHERE d.location_id = l.id))::int * 2 + "
      "(EXISTS (SELECT 1 FROM engine_state s WHERE s.key = $1 || l.id))::int * 4 + "
      "(EXISTS (SELECT 1 FROM wm_entries w WHERE w.location_id = l.id))::int * 8",
      detail::PgParams().add(std::string(kLocationKeypointsKeyPrefix)));
  // Digests a range of locations at a time: the references of a large map do not fit in one
  // result.
  constexpr std::int64_t kRange = 4096;
  const std::int64_t last = db_->run("SELECT coalesce(max(id), 0) FROM locations").integer(0, 0);
  for (std::int64_t first = 0; first <= last; first += kRange) {
    const std::int64_t end = first + kRange;
    const auto locations = db_->run("SELECT id FROM locations WHERE id >= $1 AND id < $2",
                                    detail::PgParams().add(first).add(end));
    const auto refs = db_->run(
        "SELECT location_id, word_id, x, y, size, angle, response FROM word_refs "
        "WHERE location_id >= $1 AND location_id < $2 ORDER BY location_id, ordinal",
        detail::PgParams().add(first).add(end));
    std::map<std::int64_t, detail::RefsDigest> digests;
    for (int i = 0; i < locations.rows(); ++i)
      digests.emplace(locations.integer(i, 0), detail::RefsDigest(locations.integer(i, 0)));
    for (int i = 0; i < refs.rows(); ++i) {
      const auto it = digests.find(refs.integer(i, 0));
      if (it != digests.end())
        it->second.add(refs.integer(i, 1), refs.real(i, 2), refs.real(i, 3), refs.real(i, 4),
                       refs.real(i, 5), refs.real(i, 6));
    }
    std::vector<std::int64_t> ids, values;
    for (const auto& [id, digest] : digests) {
      ids.push_back(id);
      values.push_back(digest.value());
    }
    db_->run(
        "UPDATE locations l SET refs_digest = u.d FROM unnest($1::int8[], $2::int8[]) AS u(id, d) "
        "WHERE l.id = u.id",
        detail::PgParams().addArray(ids).addArray(values));
  }
}

int PgMapStore::schemaVersion() const {
  const auto r = db_->run("SELECT value FROM placedb_meta WHERE key = 'schema_version'");
  if (r.rows() == 0) return 0;
  try {
    return std::stoi(r.text(0, 0));
  } catch (const std::exception&) {
    throw StorageError(ErrorCode::kMapRefused,
                       "map " + label_ + " damaged: placedb_meta schema_version is not a number");
  }
}

void PgMapStore::requireWritable() const {
  if (read_only_) throw StorageError(ErrorCode::kReadOnly, "map " + label_ + " is open read-only");
}

detail::WriteScope PgMapStore::writeScope() {
  requireWritable();
  return detail::WriteScope(*db_);
}

ReadSnapshot PgMapStore::readSnapshot() const { return ReadSnapshot(db_.get()); }

Transaction PgMapStore::begin() {
  requireWritable();
  return Transaction(db_.get());
}

// ---- Sessions ----

std::int64_t PgMapStore::beginSession(const std::string& source,
                                      const std::map<std::string, std::string>& settings,
                                      const std::string& software_version) {
  auto scope = writeScope();
  // Ids are max + 1, as a file's rowids: writers beginning at once take turns (the next
  // statement's snapshot sees the session the one before committed).
  db_->run("SELECT pg_advisory_xact_lock($1)", detail::PgParams().add(kSessionsKey));
  static const std::string insert =
      std::string(
          "INSERT INTO sessions (id, started_at, software_version, source) VALUES ((SELECT "
          "coalesce(max(id), 0) + 1 FROM sessions), ") +
      kNowText + ", $1, $2) RETURNING id";
  const std::int64_t id =
      db_->run(insert.c_str(), detail::PgParams().add(software_version).add(source)).integer(0, 0);
  if (!settings.empty()) {
    std::vector<std::string> keys, values;
    for (const auto& [key, value] : settings) {
      keys.push_back(key);
      values.push_back(value);
    }
    db_->send(
        "INSERT INTO settings (session_id, key, value) SELECT $1, k, v FROM unnest($2::text[], "
        "$3::text[]) AS t(k, v)",
        detail::PgParams().add(id).addArray(keys).addArray(values));
  }
  db_->send(
      "UPDATE sessions SET settings_digest = $2 WHERE id = $1",
      detail::PgParams().add(id).add(std::int64_t{detail::settingsDigest(id, source, settings)}));
  scope.commit();
  return id;
}

void PgMapStore::setSourceDigest(std::int64_t session_id, const std::string& digest) {
  auto scope = writeScope();
  db_->send("UPDATE sessions SET source_digest = $2 WHERE id = $1",
            detail::PgParams().add(session_id).add(digest));
  scope.commit();
}

void PgMapStore::endSession(std::int64_t session_id, bool clean) {
  auto scope = writeScope();
  static const std::string update = std::string("UPDATE sessions SET ended_at = ") + kNowText +
                                    ", clean_close = $2 WHERE id = $1";
  const auto r =
      db_->run(update.c_str(), detail::PgParams().add(session_id).add(std::int64_t{clean}));
  if (r.changed() != 1)
    throw StorageError(ErrorCode::kInvalidArgument, "no session " + std::to_string(session_id));
  scope.commit();
}

void PgMapStore::reopenSession(std::int64_t session_id) {
  auto scope = writeScope();
  const auto r = db_->run("UPDATE sessions SET ended_at = NULL, clean_close = 0 WHERE id = $1",
                          detail::PgParams().add(session_id));
  if (r.changed() != 1)
    throw StorageError(ErrorCode::kInvalidArgument, "no session " + std::to_string(session_id));
  scope.commit();
}

std::vector<SessionRecord> PgMapStore::sessions() const {
  static const std::string select = std::string(kSessionColumns) + "ORDER BY id";
  const auto r = db_->run(select.c_str());
  std::vector<SessionRecord> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back(readSession(r, i));
  return out;
}

std::optional<SessionRecord> PgMapStore::lastSession() const {
  static const std::string select = std::string(kSessionColumns) + "ORDER BY id DESC LIMIT 1";
  const auto r = db_->run(select.c_str());
  if (r.rows() == 0) return std::nullopt;
  return readSession(r, 0);
}

std::map<std::string, std::string> PgMapStore::settings(std::int64_t session_id) const {
  const auto r = db_->run("SELECT key, value FROM settings WHERE session_id = $1",
                          detail::PgParams().add(session_id));
  std::map<std::string, std::string> out;
  for (int i = 0; i < r.rows(); ++i) out[r.text(i, 0)] = r.text(i, 1);
  // A setting deleted would resume the session with its default, one added with another value.
  const auto digest = db_->run("SELECT source, settings_digest FROM sessions WHERE id = $1",
                               detail::PgParams().add(session_id));
  if (digest.rows() > 0 && digest.optionalInteger(0, 1) != std::int64_t{detail::settingsDigest(
                                                               session_id, digest.text(0, 0), out)})
    detail::refuseDamagedRow(label_, "settings", "of session " + std::to_string(session_id),
                             "do not match the session's settings_digest (a setting was deleted, "
                             "added or changed, or the session's source)");
  return out;
}

// ---- Frames ----

std::int64_t PgMapStore::insertFrame(const FrameRecord& f) {
  auto scope = writeScope();
  static const std::string insert =
      std::string("INSERT INTO frames (") + kFrameColumns +
      ") VALUES (coalesce($1, (SELECT coalesce(max(id), 0) + 1 FROM frames)), $2, $3, $4, $5, "
      "$6, $7, $8, $9, $10, $11, $12, $13, $14, $15, $16, $17, $18, $19, $20) RETURNING id";
  detail::PgParams p;
  p.add(f.id != 0 ? std::optional<std::int64_t>(f.id) : std::nullopt)
      .add(f.session_id)
      .add(f.source_index)
      .add(f.source_path)
      .add(std::int64_t{static_cast<int>(f.outcome)})
      .add(f.location_id);
  const FrameTimings& t = f.timings;
  for (double ms : {t.features_ms, t.quantisation_ms, t.likelihood_ms, t.filter_ms, t.memory_ms,
                    t.storage_ms, t.total_ms})
    p.add(ms);
  const FrameStats& st = f.stats;
  for (std::int64_t v :
       {st.feature_count, st.words_created, st.vocabulary_size, st.wm_size, st.stm_size})
    p.add(v);
  p.add(st.mean_quantisation_error).add(f.stamp_ns);
  const std::int64_t id = db_->run(insert.c_str(), p).integer(0, 0);
  scope.commit();
  return id;
}

std::optional<FrameRecord> PgMapStore::frame(std::int64_t frame_id) const {
  static const std::string select =
      std::string("SELECT ") + kFrameColumns + " FROM frames WHERE id = $1";
  const auto r = db_->run(select.c_str(), detail::PgParams().add(frame_id));
  if (r.rows() == 0) return std::nullopt;
  return readFrame(r, 0);
}

std::vector<FrameRecord> PgMapStore::frames(std::int64_t session_id) const {
  static const std::string select = std::string("SELECT ") + kFrameColumns +
                                    " FROM frames WHERE session_id = $1 ORDER BY source_index";
  const auto r = db_->run(select.c_str(), detail::PgParams().add(session_id));
  std::vector<FrameRecord> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back(readFrame(r, i));
  return out;
}

std::optional<std::int64_t> PgMapStore::lastFrameIndex(std::int64_t session_id) const {
  return db_
      ->run("SELECT max(source_index) FROM frames WHERE session_id = $1",
            detail::PgParams().add(session_id))
      .optionalInteger(0, 0);
}

std::int64_t PgMapStore::frameCount() const {
  return db_->run("SELECT count(*) FROM frames").integer(0, 0);
}

std::int64_t PgMapStore::frameCount(std::int64_t session_id) const {
  return db_
      ->run("SELECT count(*) FROM frames WHERE session_id = $1", detail::PgParams().add(session_id))
      .integer(0, 0);
}

std::int64_t PgMapStore::frameCount(FrameOutcome outcome) const {
  return db_
      ->run("SELECT count(*) FROM frames WHERE outcome = $1",
            detail::PgParams().add(static_cast<std::int64_t>(outcome)))
      .integer(0, 0);
}

std::optional<FrameRecord> PgMapStore::lastFrame() const {
  static const std::string select =
      std::string("SELECT ") + kFrameColumns + " FROM frames ORDER BY id DESC LIMIT 1";
  const auto r = db_->run(select.c_str());
  if (r.rows() == 0) return std::nullopt;
  return readFrame(r, 0);
}

// ---- Locations ----

void PgMapStore::insertLocation(const LocationRecord& l) {
  if (side_session_) return sideInsertLocation(l);
  auto scope = writeScope();
  // It holds no other row yet: each is marked as it is written (location_rows.h).
  fresh_locations_.insert(l.id);
  db_->send(
      "INSERT INTO locations (id, session_id, weight, tier, created_frame, held, refs_digest, "
      "checksum, link_count) VALUES ($1, $2, $3, $4, $5, 0, $6, $7, 0)",
      detail::PgParams()
          .add(l.id)
          .add(l.session_id)
          .add(l.weight)
          .add(std::int64_t{static_cast<int>(l.tier)})
          .add(l.created_frame)
          .add(std::int64_t{detail::refsDigest(l.id, {})})
          .add(std::int64_t{
              detail::locationChecksum(l.id, l.session_id, l.weight, l.created_frame)}));
  scope.commit();
}

void PgMapStore::markHeld(std::int64_t location_id, std::int64_t bit, bool held) {
  // Unchanged rows are not written again (a location brought back keeps its WM age bit).
  db_->send(held ? "UPDATE locations SET held = held | $2 WHERE id = $1 AND (held & $2) = 0"
                 : "UPDATE locations SET held = held & ~$2 WHERE id = $1 AND (held & $2) <> 0",
            detail::PgParams().add(location_id).add(bit));
}

void PgMapStore::updateWeight(std::int64_t location_id, std::int64_t weight) {
  auto scope = writeScope();
  const auto r =
      db_->run("UPDATE locations SET weight = $2 WHERE id = $1 RETURNING session_id, created_frame",
               detail::PgParams().add(location_id).add(weight));
  if (r.rows() != 1)
    throw StorageError(ErrorCode::kInvalidArgument, "no location " + std::to_string(location_id));
  db_->send("UPDATE locations SET checksum = $2 WHERE id = $1",
            detail::PgParams()
                .add(location_id)
                .add(std::int64_t{detail::locationChecksum(location_id, r.integer(0, 0), weight,
                                                           r.optionalInteger(0, 1))}));
  scope.commit();
}

void PgMapStore::setTier(const std::vector<std::int64_t>& location_ids, Tier tier) {
  if (location_ids.empty()) return requireWritable();
  if (side_session_) return sideSetTier(location_ids, tier);
  auto scope = writeScope();
  db_->send("UPDATE locations SET tier = $2 WHERE id = ANY($1)",
            detail::PgParams().addArray(location_ids).add(std::int64_t{static_cast<int>(tier)}));
  scope.commit();
}

void PgMapStore::deleteLocation(std::int64_t location_id) {
  auto scope = writeScope();
  db_->send(
      // The view's trigger removes the entry from the posterior's arrays (migrations/pg/0018).
      "WITH p AS (DELETE FROM filter_posterior WHERE location_id = $1), "
      "k AS (DELETE FROM engine_state WHERE key IN ($2, $3)), "
      // No key cascades a location's references since schema 16 (migrations/pg/0016).
      "r AS (DELETE FROM word_refs WHERE location_id = $1), "
      "n AS (UPDATE locations o SET link_count = o.link_count - (SELECT count(*) FROM links k "
      "WHERE (k.location_a = $1 AND k.location_b = o.id) OR (k.location_b = $1 AND "
      "k.location_a = o.id)) WHERE o.id IN (SELECT location_b FROM links WHERE location_a = $1 "
      "UNION SELECT location_a FROM links WHERE location_b = $1)) "
      "DELETE FROM locations WHERE id = $1",
      detail::PgParams()
          .add(location_id)
          .add(locationKeypointsKey(location_id))
          .add(locationLatestViewKey(location_id)));
  scope.commit();
}

void PgMapStore::addCoveredFrame(std::int64_t location_id, std::int64_t frame_id) {
  auto scope = writeScope();
  db_->send(
      "INSERT INTO location_frames (location_id, frame_id) VALUES ($1, $2) ON CONFLICT DO "
      "NOTHING",
      detail::PgParams().add(location_id).add(frame_id));
  scope.commit();
}

std::vector<std::int64_t> PgMapStore::coveredFrames(std::int64_t location_id) const {
  const auto r =
      db_->run("SELECT frame_id FROM location_frames WHERE location_id = $1 ORDER BY frame_id",
               detail::PgParams().add(location_id));
  std::vector<std::int64_t> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back(r.integer(i, 0));
  return out;
}

std::map<std::int64_t, std::vector<std::int64_t>> PgMapStore::coveredFrames(
    const std::vector<std::int64_t>& location_ids) const {
  std::map<std::int64_t, std::vector<std::int64_t>> out;
  for (std::int64_t id : location_ids) out[id];
  const auto r = db_->run(
      "SELECT location_id, frame_id FROM location_frames WHERE location_id = ANY($1) "
      "ORDER BY location_id, frame_id",
      detail::PgParams().addArray(location_ids));
  for (int i = 0; i < r.rows(); ++i) out[r.integer(i, 0)].push_back(r.integer(i, 1));
  return out;
}

std::vector<LocationWeight> PgMapStore::locationsInTier(Tier tier) const {
  if (side_session_) return sideLocationsInTier(tier);
  const auto r = db_->run("SELECT id, weight FROM locations WHERE tier = $1 ORDER BY id",
                          detail::PgParams().add(std::int64_t{static_cast<int>(tier)}));
  std::vector<LocationWeight> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back({r.integer(i, 0), r.integer(i, 1)});
  return out;
}

std::optional<LocationRecord> PgMapStore::location(std::int64_t location_id) const {
  const auto r =
      db_->run("SELECT id, session_id, weight, tier, created_frame FROM locations WHERE id = $1",
               detail::PgParams().add(location_id));
  if (r.rows() == 0) return std::nullopt;
  return LocationRecord{r.integer(0, 0), r.integer(0, 1), r.integer(0, 2),
                        static_cast<Tier>(r.integer(0, 3)), r.optionalInteger(0, 4)};
}

std::int64_t PgMapStore::locationCount() const {
  return db_->run("SELECT count(*) FROM locations").integer(0, 0);
}

}  // namespace placedb::storage
