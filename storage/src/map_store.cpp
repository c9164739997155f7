// MapStore's backend-neutral parts: transactions over a TransactionControl, and the factory
// that picks a backend from the map's name.
#include "placedb/storage/map_store.h"

#include "pg_map_store.h"
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
