// MapStore: what the memory tiers keep beside the locations: place codes and WM ages.
#include <cstring>

#include "placedb/storage/sqlite_map_store.h"
#include "sqlite/database.h"
#include "sqlite/sqlite_checksums.h"
#include "sqlite/sqlite_location_rows.h"

namespace placedb::storage {

void SqliteMapStore::putPlaceCode(std::int64_t location_id, const std::vector<std::int8_t>& code) {
  auto scope = writeScope();
  auto s = db_->cached(
      "INSERT OR REPLACE INTO place_codes (location_id, code, checksum) VALUES (?1, ?2, ?3)");
  s->bind(1, location_id);
  s->bindBlob(2, code.data(), code.size());
  s->bind(3, std::int64_t{detail::placeCodeChecksum(location_id, code.data(), code.size())});
  s->run();
  markHeld(location_id, detail::kHeldPlaceCode, true);
  scope.commit();
}

std::vector<PlaceCodeRecord> SqliteMapStore::placeCodes() const {
  auto s = db_->cached("SELECT location_id, code, checksum FROM place_codes ORDER BY location_id");
  std::vector<PlaceCodeRecord> result;
  while (s->step()) {
    const auto [data, size] = s->columnBlobView(1);
    if (!detail::checksumMatches(*s, 2, detail::placeCodeChecksum(s->columnInt(0), data, size)))
      detail::refuseDamagedRow(path_, "place_codes", std::to_string(s->columnInt(0)),
                               "fails its checksum");
    PlaceCodeRecord r{s->columnInt(0), std::vector<std::int8_t>(size)};
    if (size) std::memcpy(r.code.data(), data, size);
    result.push_back(std::move(r));
  }
  return result;
}

std::optional<std::vector<std::int8_t>> SqliteMapStore::placeCode(std::int64_t location_id) const {
  auto s = db_->cached("SELECT code, checksum FROM place_codes WHERE location_id = ?1");
  s->bind(1, location_id);
  if (!s->step()) return std::nullopt;
  const auto [data, size] = s->columnBlobView(0);
  if (!detail::checksumMatches(*s, 1, detail::placeCodeChecksum(location_id, data, size)))
    detail::refuseDamagedRow(path_, "place_codes", std::to_string(location_id),
                             "fails its checksum");
  std::vector<std::int8_t> code(size);
  if (size) std::memcpy(code.data(), data, size);
  return code;
}

void SqliteMapStore::setWmAges(const std::vector<std::pair<std::int64_t, std::int64_t>>& ages) {
  auto scope = writeScope();
  auto s = db_->cached(
      "INSERT OR REPLACE INTO wm_entries (location_id, wm_age, checksum) VALUES (?1, ?2, ?3)");
  for (const auto& [id, age] : ages) {
    s->bind(1, id);
    s->bind(2, age);
    s->bind(3, std::int64_t{detail::wmEntryChecksum(id, age)});
    s->run();
    markHeld(id, detail::kHeldWmEntry, true);
  }
  scope.commit();
}

std::map<std::int64_t, std::int64_t> SqliteMapStore::wmAges() const {
  auto s = db_->cached(
      "SELECT l.id, coalesce(w.wm_age, l.id) FROM locations l "
      "LEFT JOIN wm_entries w ON w.location_id = l.id");
  std::map<std::int64_t, std::int64_t> result;
  while (s->step()) result.emplace(s->columnInt(0), s->columnInt(1));
  return result;
}

}  // namespace placedb::storage
