// SqliteMapStore's part in fleet maps (map_store.h, "Writers"). A file has one writer, which
// always holds the main line; a file copied from a fleet map keeps its side sessions' rows (so
// that a copy back to a server can resume them) but never reads or writes them, and reserves ids
// past every id of the copy once its counters reach the end of the block they held.
#include <cstring>

#include "placedb/storage/sqlite_map_store.h"
#include "sqlite/database.h"
#include "sqlite/sqlite_checksums.h"

namespace placedb::storage {

bool SqliteMapStore::sharedByWriters() const { return false; }

bool SqliteMapStore::claimMainLine() { return !read_only_; }  // the file's lock is the writer's

void SqliteMapStore::releaseMainLine() {}

SessionMemory SqliteMapStore::sessionMemory(std::int64_t session_id) const {
  // The main line's newest session is the newest one without memory of its own.
  auto s = db_->cached(
      "SELECT CASE WHEN EXISTS (SELECT 1 FROM session_state WHERE session_id = ?1) THEN 2 "
      "WHEN ?1 = (SELECT max(id) FROM sessions s WHERE NOT EXISTS "
      "(SELECT 1 FROM session_state t WHERE t.session_id = s.id)) THEN 1 ELSE 0 END");
  s->bind(1, session_id);
  s->step();
  return static_cast<SessionMemory>(s->columnInt(0));
}

void SqliteMapStore::claimSession(std::int64_t) {}  // the file's lock already excludes others

void SqliteMapStore::releaseSession(std::int64_t) {}

std::int64_t SqliteMapStore::beginSideSession(const std::string&,
                                              const std::map<std::string, std::string>&,
                                              const std::string&) {
  throw StorageError(ErrorCode::kInternal,
                     "map " + path_ + ": a file has one writer, which holds the main line");
}

std::int64_t SqliteMapStore::keepUnfinishedMainLine() { return 0; }

void SqliteMapStore::useSideMemory(std::int64_t session_id) {
  throw StorageError(ErrorCode::kInvalidArgument,
                     "map " + path_ + ": session " + std::to_string(session_id) +
                         " wrote a fleet map on a server and keeps its memory in rows of its "
                         "own, which a file does not continue; copy the map to a server to "
                         "resume it, or map a new session");
}

IdBlock SqliteMapStore::reserveIds(IdKind kind, std::int64_t count, std::int64_t next) {
  auto scope = writeScope();
  // One writer: past the ids in the tables (a copied fleet map's other sessions included).
  static const char* const kReserve[] = {
      "INSERT INTO id_blocks (kind, next) VALUES ('frame', max(?1, (SELECT coalesce(max(id) + 1, "
      "1) FROM frames)) + ?2) ON CONFLICT (kind) DO UPDATE SET next = max(id_blocks.next, ?1, "
      "(SELECT coalesce(max(id) + 1, 1) FROM frames)) + ?2 RETURNING next - ?2",
      "INSERT INTO id_blocks (kind, next) VALUES ('location', max(?1, (SELECT coalesce(max(id) + "
      "1, 1) FROM locations)) + ?2) ON CONFLICT (kind) DO UPDATE SET next = max(id_blocks.next, "
      "?1, (SELECT coalesce(max(id) + 1, 1) FROM locations)) + ?2 RETURNING next - ?2",
      "INSERT INTO id_blocks (kind, next) VALUES ('word', max(?1, (SELECT coalesce(max(id) + 1, "
      "0) FROM words)) + ?2) ON CONFLICT (kind) DO UPDATE SET next = max(id_blocks.next, ?1, "
      "(SELECT coalesce(max(id) + 1, 0) FROM words)) + ?2 RETURNING next - ?2"};
  auto s = db_->cached(kReserve[static_cast<int>(kind)]);
  s->bind(1, next);
  s->bind(2, count);
  s->step();
  const IdBlock block{s->columnInt(0), s->columnInt(0) + count};
  s->reset();
  scope.commit();
  return block;
}

std::map<std::int64_t, std::int64_t> SqliteMapStore::newestLocations() const {
  auto s = db_->cached("SELECT session_id, max(id) FROM locations GROUP BY session_id");
  std::map<std::int64_t, std::int64_t> out;
  while (s->step()) out[s->columnInt(0)] = s->columnInt(1);
  return out;
}

std::vector<SharedPlace> SqliteMapStore::placesAfter(
    std::int64_t session_id, const std::map<std::int64_t, std::int64_t>& newest) const {
  // No other writer can store a place while this one writes; for tools that read a copy.
  auto s = db_->cached(
      "SELECT l.id, l.session_id, l.weight, p.code, p.checksum FROM locations l "
      "LEFT JOIN place_codes p ON p.location_id = l.id WHERE l.session_id <> ?1 ORDER BY l.id");
  s->bind(1, session_id);
  std::vector<SharedPlace> out;
  while (s->step()) {
    const std::int64_t id = s->columnInt(0);
    const auto mark = newest.find(s->columnInt(1));
    if (mark != newest.end() && id <= mark->second) continue;
    SharedPlace place{id, s->columnInt(1), s->columnInt(2), {}};
    if (!s->isNull(3)) {
      const auto [data, size] = s->columnBlobView(3);
      if (!detail::checksumMatches(*s, 4, detail::placeCodeChecksum(id, data, size)))
        detail::refuseDamagedRow(path_, "place_codes", std::to_string(id), "fails its checksum");
      place.code.resize(size);
      if (size) std::memcpy(place.code.data(), data, size);
    }
    out.push_back(std::move(place));
  }
  return out;
}

}  // namespace placedb::storage
