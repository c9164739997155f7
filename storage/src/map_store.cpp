// MapStore's backend-neutral parts: transactions over a TransactionControl, reading a location's
// words back, and the factory that picks a backend from the map's name.
#include "placedb/storage/map_store.h"

#include <algorithm>
#include <cstring>

#include "backends.h"
#include "placedb/storage/migrations.h"
#include "placedb/storage/sqlite_map_store.h"

namespace placedb::storage {

bool isServerMap(const std::string& map) {
  return map.rfind("postgresql://", 0) == 0 || map.rfind("postgres://", 0) == 0;
}

std::unique_ptr<MapStore> openMapStore(const std::string& map, OpenMode mode,
                                       const OpenOptions& options) {
  if (isServerMap(map)) return openPgMapStore(map, mode, options);
  return std::make_unique<SqliteMapStore>(map, mode, options);
}

int MapStore::currentSchemaVersion() { return storage::currentSchemaVersion(); }

void MapStore::loadLocationDescriptors(const std::vector<std::int64_t>& location_ids,
                                       const std::vector<std::int64_t>& word_ids, int dim,
                                       float* rows, std::int64_t* created) const {
  if (!std::is_sorted(word_ids.begin(), word_ids.end()))
    throw StorageError(ErrorCode::kInvalidArgument, "loadLocationDescriptors: ids must be sorted");
  const std::size_t row_floats = static_cast<std::size_t>(dim);
  std::vector<char> found(word_ids.size(), 0);
  // No locations, no rows to read (a server would still be asked once).
  const auto stored_rows = location_ids.empty() ? std::vector<LocationWordDescriptors>()
                                                : locationWordDescriptors(location_ids);
  for (const LocationWordDescriptors& stored : stored_rows) {
    if (stored.dim != dim)
      throw StorageError(ErrorCode::kMapRefused,
                         "map " + path() + ": the word descriptors of location " +
                             std::to_string(stored.location_id) + " are not of dimension " +
                             std::to_string(dim));
    // Both lists ascend.
    std::size_t i = 0, j = 0;
    while (i < word_ids.size() && j < stored.word_ids.size()) {
      if (word_ids[i] < stored.word_ids[j]) {
        ++i;
      } else if (stored.word_ids[j] < word_ids[i]) {
        ++j;
      } else {
        if (!found[i]) {
          std::memcpy(rows + i * row_floats, stored.descriptors.data() + j * row_floats,
                      row_floats * sizeof(float));
          created[i] = stored.created_frames[j];
          found[i] = 1;
        }
        ++i;
        ++j;
      }
    }
  }
  // Locations made before schema 13 have no row; imported words are in none.
  std::vector<std::int64_t> rest;
  for (std::size_t i = 0; i < word_ids.size(); ++i)
    if (!found[i]) rest.push_back(word_ids[i]);
  if (rest.empty()) return;
  std::vector<float> rest_rows(rest.size() * row_floats);
  std::vector<std::int64_t> rest_created(rest.size());
  loadFloatDescriptors(rest, dim, rest_rows.data(), rest_created.data());
  for (std::size_t i = 0, k = 0; i < word_ids.size(); ++i) {
    if (found[i]) continue;
    std::memcpy(rows + i * row_floats, rest_rows.data() + k * row_floats,
                row_floats * sizeof(float));
    created[i] = rest_created[k++];
  }
}

// ---- Transaction ----

Transaction::Transaction(TransactionControl* control) : control_(control) {
  if (control_->inTransaction()) {
    throw StorageError(ErrorCode::kInternal,
                       "a transaction is already open on " + control_->label());
  }
  control_->beginWrite();
}

Transaction::Transaction(Transaction&& other) noexcept : control_(other.control_) {
  other.control_ = nullptr;
}

Transaction::~Transaction() {
  if (control_ && control_->inTransaction()) control_->rollbackQuietly();
}

void Transaction::commit() {
  if (!control_) throw StorageError(ErrorCode::kInternal, "commit of a finished transaction");
  TransactionControl* control = control_;
  control_ = nullptr;
  control->commit();
}

void Transaction::rollback() {
  if (!control_) return;
  TransactionControl* control = control_;
  control_ = nullptr;
  if (control->inTransaction()) control->rollback();
}

// ---- ReadSnapshot ----

ReadSnapshot::ReadSnapshot(TransactionControl* control) : control_(control) {
  if (control_->inTransaction()) {
    control_ = nullptr;  // the open transaction already gives one snapshot
    return;
  }
  control_->beginRead();
}

ReadSnapshot::ReadSnapshot(ReadSnapshot&& other) noexcept : control_(other.control_) {
  other.control_ = nullptr;
}

ReadSnapshot::~ReadSnapshot() {
  // Nothing was written: ending it cannot lose data, and a destructor must not throw.
  if (control_ && control_->inTransaction()) control_->endReadQuietly();
}

}  // namespace placedb::storage
