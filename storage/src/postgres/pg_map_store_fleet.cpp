// PgMapStore's fleet map: several writers at once, each in a session of its own
// (schema/SCHEMA.md, "Fleet maps").
//
// - Locks. The main line's writer holds kWriterLockKey; every writer holds its session's lock
//   (kSessionLockClass, session id). Both are session-level advisory locks: the server drops them
//   when the writer's connection ends, so a killed writer never leaves its session taken.
// - Side sessions. A writer that begins while another holds the main line copies the main line's
//   memory into rows of its own (one statement, so one snapshot) and from then on reads and writes
//   only those: the side* methods below, which the MapStore methods call when side_session_ is set.
// - Ids come from blocks reserved in id_blocks within the frame's transaction: a frame that rolls
//   back gives its block back, so a lone writer numbers rows exactly as a file does.
// - Robots' guards (schema 15, keyed to the owner in schema 21): a writer other than the owner
//   is refused at its open when they name a role that no longer exists.
#include <cstring>

#include "postgres/pg_map_store.h"
#include "row_checksums.h"

namespace placedb::storage {
namespace {

bool sumMatches(const detail::PgResult& r, int row, int column, std::uint32_t computed) {
  return !r.isNull(row, column) && r.integer(row, column) == std::int64_t{computed};
}

}  // namespace

bool isWriterStateKey(const std::string& key) {
  for (const std::string& k : writerStateKeys())
    if (k == key) return true;
  return false;
}

const std::vector<std::string>& writerStateKeys() {
  static const std::vector<std::string> kKeys = {"engine.counters", "vocabulary.header",
                                                 detail::kKdNodeRowsKey};
  return kKeys;
}

bool PgMapStore::sharedByWriters() const { return true; }

bool PgMapStore::claimMainLine() {
  if (read_only_) return false;
  if (!main_line_)
    main_line_ = db_->run("SELECT pg_try_advisory_lock($1)", detail::PgParams().add(kWriterLockKey))
                     .boolean(0, 0);
  return main_line_;
}

void PgMapStore::releaseMainLine() {
  if (!main_line_) return;
  db_->run("SELECT pg_advisory_unlock($1)", detail::PgParams().add(kWriterLockKey));
  main_line_ = false;
}

SessionMemory PgMapStore::sessionMemory(std::int64_t session_id) const {
  // The main line's newest session is the newest one without memory of its own.
  return static_cast<SessionMemory>(
      db_->run("SELECT CASE WHEN EXISTS (SELECT 1 FROM session_state WHERE session_id = $1) "
               "THEN 2 WHEN $1 = (SELECT max(id) FROM sessions s WHERE NOT EXISTS (SELECT 1 "
               "FROM session_state t WHERE t.session_id = s.id)) THEN 1 ELSE 0 END",
               detail::PgParams().add(session_id))
          .integer(0, 0));
}

void PgMapStore::claimSession(std::int64_t session_id) {
  requireWritable();
  if (claimed_.count(session_id)) return;
  const bool taken = db_->run("SELECT pg_try_advisory_lock($1::int4, $2::int4)",
                              detail::PgParams().add(kSessionLockClass).add(session_id))
                         .boolean(0, 0);
  if (!taken)
    throw StorageError(ErrorCode::kMapBusy, "map " + label_ + " is busy: session " +
                                                std::to_string(session_id) +
                                                " is being written by another placedb writer");
  claimed_.insert(session_id);
}

void PgMapStore::releaseSession(std::int64_t session_id) {
  if (!claimed_.erase(session_id)) return;
  db_->run("SELECT pg_advisory_unlock($1::int4, $2::int4)",
           detail::PgParams().add(kSessionLockClass).add(session_id));
  if (side_session_ == session_id) side_session_ = 0;
}

std::int64_t PgMapStore::beginSideSession(const std::string& source,
                                          const std::map<std::string, std::string>& settings,
                                          const std::string& software_version) {
  requireWritable();
  if (!db_->inTransaction())
    throw StorageError(ErrorCode::kInternal, "beginSideSession outside a transaction");
  const std::int64_t id = beginSession(source, settings, software_version);
  copyMainLineMemory(id);
  claimSession(id);
  side_session_ = id;
  return id;
}

void PgMapStore::copyMainLineMemory(std::int64_t session_id) {
  // One statement, one snapshot: the main line commits a frame as a whole, so the copy is the
  // memory it had after one of its frames.
  db_->run(
      "WITH s AS (INSERT INTO session_state (session_id, key, value, checksum) "
      "  SELECT $1, key, value, checksum FROM engine_state WHERE key = ANY($2)), "
      "k AS (INSERT INTO session_kd_nodes SELECT $1, tree, node, left_child, right_child, "
      "  split_dim, split_value, checksum FROM kd_nodes), "
      "p AS (INSERT INTO session_posterior_vectors SELECT $1, location_ids, probabilities "
      "  FROM filter_posterior_vector) "
      "INSERT INTO session_memory (session_id, location_id, tier, wm_age) "
      "SELECT $1, l.id, l.tier, w.wm_age FROM locations l "
      "LEFT JOIN wm_entries w ON w.location_id = l.id WHERE l.tier IN (0, 1)",
      detail::PgParams().add(session_id).addArray(writerStateKeys()));
}

std::int64_t PgMapStore::keepUnfinishedMainLine() {
  requireWritable();
  if (!main_line_ || !db_->inTransaction())
    throw StorageError(ErrorCode::kInternal,
                       "keepUnfinishedMainLine needs the main line and an open transaction");
  // The main line's newest session is the newest one without memory of its own; holding the
  // main line, this writer knows no other writer continues it.
  const auto r = db_->run(
      "SELECT s.id FROM sessions s WHERE s.clean_close = 0 AND s.id = (SELECT max(id) FROM "
      "sessions t WHERE NOT EXISTS (SELECT 1 FROM session_state u WHERE u.session_id = t.id))");
  if (r.rows() == 0) return 0;
  const std::int64_t id = r.integer(0, 0);
  copyMainLineMemory(id);
  return id;
}

void PgMapStore::useSideMemory(std::int64_t session_id) {
  requireWritable();
  side_session_ = session_id;
}

IdBlock PgMapStore::reserveIds(IdKind kind, std::int64_t count, std::int64_t next) {
  auto scope = writeScope();
  // The row lock on the kind's row holds other writers' reservations until this transaction
  // ends. max(id) covers ids that came with a copy or an older map, which no block accounts for.
  static const char* const kReserve[] = {
      "INSERT INTO id_blocks (kind, next) VALUES ('frame', greatest($1, (SELECT coalesce(max(id) "
      "+ 1, 1) FROM frames)) + $2) ON CONFLICT (kind) DO UPDATE SET next = greatest("
      "id_blocks.next, $1, (SELECT coalesce(max(id) + 1, 1) FROM frames)) + $2 RETURNING next - $2",
      "INSERT INTO id_blocks (kind, next) VALUES ('location', greatest($1, (SELECT coalesce("
      "max(id) + 1, 1) FROM locations)) + $2) ON CONFLICT (kind) DO UPDATE SET next = greatest("
      "id_blocks.next, $1, (SELECT coalesce(max(id) + 1, 1) FROM locations)) + $2 "
      "RETURNING next - $2",
      "INSERT INTO id_blocks (kind, next) VALUES ('word', greatest($1, (SELECT coalesce(max(id) "
      "+ 1, 0) FROM words)) + $2) ON CONFLICT (kind) DO UPDATE SET next = greatest("
      "id_blocks.next, $1, (SELECT coalesce(max(id) + 1, 0) FROM words)) + $2 RETURNING next - $2"};
  const std::int64_t first =
      db_->run(kReserve[static_cast<int>(kind)], detail::PgParams().add(next).add(count))
          .integer(0, 0);
  scope.commit();
  return {first, first + count};
}

std::map<std::int64_t, std::int64_t> PgMapStore::newestLocations() const {
  const auto r = db_->run("SELECT session_id, max(id) FROM locations GROUP BY session_id");
  std::map<std::int64_t, std::int64_t> out;
  for (int i = 0; i < r.rows(); ++i) out[r.integer(i, 0)] = r.integer(i, 1);
  return out;
}

std::vector<SharedPlace> PgMapStore::placesAfter(
    std::int64_t session_id, const std::map<std::int64_t, std::int64_t>& newest) const {
  std::vector<std::int64_t> sessions, marks;
  for (const auto& [session, mark] : newest) {
    sessions.push_back(session);
    marks.push_back(mark);
  }
  // One index range per session (locations_by_session), empty when it stored nothing new. The
  // mark comes in as a joined row and OFFSET 0 keeps the subquery a per-session range: pulled up
  // into the join, its bound (a subquery on the marks) was tested on every location of the map,
  // each frame.
  const auto r = db_->run(
      "SELECT l.id, l.session_id, l.weight, p.code, p.checksum FROM sessions s "
      "LEFT JOIN unnest($2::int8[], $3::int8[]) AS n(s, m) ON n.s = s.id "
      "CROSS JOIN LATERAL (SELECT id, session_id, weight FROM locations WHERE session_id = s.id "
      "  AND id > coalesce(n.m, 0) OFFSET 0) l "
      "LEFT JOIN place_codes p ON p.location_id = l.id WHERE s.id <> $1 ORDER BY l.id",
      detail::PgParams().add(session_id).addArray(sessions).addArray(marks));
  std::vector<SharedPlace> out;
  for (int i = 0; i < r.rows(); ++i) {
    SharedPlace place{r.integer(i, 0), r.integer(i, 1), r.integer(i, 2), {}};
    if (!r.isNull(i, 3)) {
      const auto [data, size] = r.bytes(i, 3);
      if (!sumMatches(r, i, 4, detail::placeCodeChecksum(place.location_id, data, size)))
        detail::refuseDamagedRow(label_, "place_codes", std::to_string(place.location_id),
                                 "fails its checksum");
      place.code.resize(size);
      if (size) std::memcpy(place.code.data(), data, size);
    }
    out.push_back(std::move(place));
  }
  return out;
}

// ---- Robots' guards ----

void PgMapStore::refuseGuardsOfMissingRole() {
  // Guards still keyed to a role that no longer exists (the owner renamed or dropped, the owner's
  // writer not yet back) fail every write of another writer with the server's own "role does not
  // exist": said here, before any write, with what fixes it.
  const auto r = db_->run(
      "SELECT g.keyed_to, pg_get_userbyid(c.relowner) FROM placedb_unkeyed_guards() g, pg_class c "
      "WHERE c.oid = 'placedb_meta'::regclass AND g.keyed_to IS NOT NULL AND NOT EXISTS "
      "(SELECT 1 FROM pg_roles o WHERE o.rolname = g.keyed_to) ORDER BY 1 LIMIT 1");
  if (r.rows() == 0) return;
  throw StorageError(ErrorCode::kMapRefused,
                     "map " + label_ + " refused: its guards are keyed to role " + r.text(0, 0) +
                         ", which no longer exists; the map's owner " + r.text(0, 1) +
                         " keys them again by opening it for writing (placedb map)");
}

// ---- A side session's own memory ----

void PgMapStore::sidePutState(const std::string& key, const void* data, std::size_t size) {
  auto scope = writeScope();
  db_->send(
      "INSERT INTO session_state (session_id, key, value, checksum) VALUES ($1, $2, $3, $4) "
      "ON CONFLICT (session_id, key) DO UPDATE SET value = excluded.value, "
      "checksum = excluded.checksum",
      detail::PgParams()
          .add(side_session_)
          .add(key)
          .addBytes(data, size)
          .add(std::int64_t{detail::stateChecksum(key, data, size)}));
  scope.commit();
}

std::optional<std::vector<std::uint8_t>> PgMapStore::sideGetState(const std::string& key) const {
  const auto r =
      db_->run("SELECT value, checksum FROM session_state WHERE session_id = $1 AND key = $2",
               detail::PgParams().add(side_session_).add(key));
  if (r.rows() == 0) return std::nullopt;
  const auto [data, size] = r.bytes(0, 0);
  if (!sumMatches(r, 0, 1, detail::stateChecksum(key, data, size)))
    detail::refuseDamagedRow(label_, "session_state",
                             std::to_string(side_session_) + " '" + key + "'",
                             "fails its checksum");
  return std::vector<std::uint8_t>(data, data + size);
}

void PgMapStore::sideDeleteState(const std::string& key) {
  auto scope = writeScope();
  db_->send("DELETE FROM session_state WHERE session_id = $1 AND key = $2",
            detail::PgParams().add(side_session_).add(key));
  scope.commit();
}

std::vector<KdNodeRecord> PgMapStore::sideLoadKdNodes() const {
  const auto r = db_->run(
      "SELECT tree, node, left_child, right_child, split_dim, split_value, checksum "
      "FROM session_kd_nodes WHERE session_id = $1 ORDER BY tree, node",
      detail::PgParams().add(side_session_));
  std::vector<KdNodeRecord> out;
  out.reserve(r.rows());
  for (int i = 0; i < r.rows(); ++i) {
    KdNodeRecord n{
        static_cast<int>(r.integer(i, 0)), r.integer(i, 1), r.integer(i, 2), r.integer(i, 3),
        static_cast<int>(r.integer(i, 4)), r.real(i, 5)};
    if (!sumMatches(r, i, 6,
                    detail::kdNodeChecksum(n.tree, n.node, n.left_child, n.right_child, n.split_dim,
                                           n.split_value)))
      detail::refuseDamagedRow(label_, "session_kd_nodes",
                               "(session " + std::to_string(side_session_) + ", tree " +
                                   std::to_string(n.tree) + ", node " + std::to_string(n.node) +
                                   ")",
                               "fails its checksum");
    out.push_back(n);
  }
  const std::int64_t stored = storedKdNodeRows();
  if (stored != static_cast<std::int64_t>(out.size()))
    throw StorageError(ErrorCode::kMapRefused,
                       "map " + label_ + " damaged: session_kd_nodes of session " +
                           std::to_string(side_session_) + " holds " + std::to_string(out.size()) +
                           " rows where the map recorded " + std::to_string(stored) +
                           "; nothing was written");
  return out;
}

void PgMapStore::sidePutPosterior(const std::vector<std::int64_t>& ids,
                                  const std::vector<double>& probabilities) {
  auto scope = writeScope();
  db_->send(
      "INSERT INTO session_posterior_vectors (session_id, location_ids, probabilities) VALUES "
      "($1, $2, $3) ON CONFLICT (session_id) DO UPDATE SET location_ids = excluded.location_ids, "
      "probabilities = excluded.probabilities",
      detail::PgParams().add(side_session_).addArray(ids).addArray(probabilities));
  scope.commit();
}

std::vector<std::pair<std::int64_t, double>> PgMapStore::sideLoadPosterior() const {
  const auto r = db_->run(
      "SELECT location_id, probability FROM session_posterior WHERE session_id = $1 "
      "ORDER BY location_id",
      detail::PgParams().add(side_session_));
  std::vector<std::pair<std::int64_t, double>> out;
  for (int i = 0; i < r.rows(); ++i) out.emplace_back(r.integer(i, 0), r.real(i, 1));
  return out;
}

void PgMapStore::sideInsertLocation(const LocationRecord& l) {
  auto scope = writeScope();
  fresh_locations_.insert(l.id);
  // In the main line's eyes another session's place is in long-term memory: not in its RAM.
  db_->send(
      "WITH l AS (INSERT INTO locations (id, session_id, weight, tier, created_frame, held, "
      "refs_digest, checksum, link_count) VALUES ($1, $2, $3, 2, $5, 0, $6, $7, 0)) INSERT INTO "
      "session_memory "
      "(session_id, location_id, tier) VALUES ($2, $1, $4)",
      detail::PgParams()
          .add(l.id)
          .add(side_session_)
          .add(l.weight)
          .add(std::int64_t{static_cast<int>(l.tier)})
          .add(l.created_frame)
          .add(std::int64_t{detail::refsDigest(l.id, {})})
          .add(std::int64_t{
              detail::locationChecksum(l.id, side_session_, l.weight, l.created_frame)}));
  scope.commit();
}

void PgMapStore::sideSetTier(const std::vector<std::int64_t>& ids, Tier tier) {
  auto scope = writeScope();
  if (tier == Tier::kLtm) {
    db_->send("DELETE FROM session_memory WHERE session_id = $1 AND location_id = ANY($2)",
              detail::PgParams().add(side_session_).addArray(ids));
  } else {
    db_->send(
        "INSERT INTO session_memory (session_id, location_id, tier) SELECT $1, unnest($2::int8[]), "
        "$3 ON CONFLICT (session_id, location_id) DO UPDATE SET tier = excluded.tier",
        detail::PgParams()
            .add(side_session_)
            .addArray(ids)
            .add(std::int64_t{static_cast<int>(tier)}));
  }
  scope.commit();
}

std::vector<LocationWeight> PgMapStore::sideLocationsInTier(Tier tier) const {
  const auto r =
      tier == Tier::kLtm
          ? db_->run(
                "SELECT id, weight FROM locations l WHERE NOT EXISTS (SELECT 1 FROM "
                "session_memory m WHERE m.session_id = $1 AND m.location_id = l.id) ORDER BY id",
                detail::PgParams().add(side_session_))
          : db_->run(
                "SELECT l.id, l.weight FROM session_memory m JOIN locations l ON l.id = "
                "m.location_id WHERE m.session_id = $1 AND m.tier = $2 ORDER BY l.id",
                detail::PgParams().add(side_session_).add(std::int64_t{static_cast<int>(tier)}));
  std::vector<LocationWeight> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back({r.integer(i, 0), r.integer(i, 1)});
  return out;
}

void PgMapStore::sideSetWmAges(const std::vector<std::int64_t>& ids,
                               const std::vector<std::int64_t>& ages) {
  auto scope = writeScope();
  // Ages of the locations in this session's STM and WM; those it moved to LTM need none (a
  // location brought back gets a new age).
  db_->send(
      "UPDATE session_memory m SET wm_age = a.age FROM unnest($2::int8[], $3::int8[]) AS a(id, "
      "age) WHERE m.session_id = $1 AND m.location_id = a.id",
      detail::PgParams().add(side_session_).addArray(ids).addArray(ages));
  scope.commit();
}

std::map<std::int64_t, std::int64_t> PgMapStore::sideWmAges() const {
  const auto r = db_->run(
      "SELECT l.id, coalesce(m.wm_age, l.id) FROM locations l LEFT JOIN session_memory m "
      "ON m.session_id = $1 AND m.location_id = l.id",
      detail::PgParams().add(side_session_));
  std::map<std::int64_t, std::int64_t> out;
  for (int i = 0; i < r.rows(); ++i) out.emplace(r.integer(i, 0), r.integer(i, 1));
  return out;
}

std::vector<std::int64_t> PgMapStore::sideLinkedInTier(std::int64_t location_id, Tier tier,
                                                       std::optional<LinkType> type) const {
  const auto r = db_->run(
      "SELECT DISTINCT k.other FROM ("
      "  SELECT location_b AS other, type FROM links WHERE location_a = $1"
      "  UNION ALL SELECT location_a, type FROM links WHERE location_b = $1) k "
      "LEFT JOIN session_memory m ON m.session_id = $2 AND m.location_id = k.other "
      "WHERE coalesce(m.tier, 2) = $3 AND ($4::int8 IS NULL OR k.type = $4) ORDER BY k.other",
      detail::PgParams()
          .add(location_id)
          .add(side_session_)
          .add(std::int64_t{static_cast<int>(tier)})
          .add(type ? std::optional<std::int64_t>(static_cast<int>(*type)) : std::nullopt));
  std::vector<std::int64_t> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back(r.integer(i, 0));
  return out;
}

}  // namespace placedb::storage
