#pragma once
// Runs a MapStore write in the caller's transaction, or in one of its own when none is open.
#include <optional>

#include "database.h"
#include "placedb/storage/map_store.h"

namespace placedb::storage {

class MapStore::WriteScope {
 public:
  explicit WriteScope(MapStore& store) {
    store.requireWritable();
    if (!store.db_->inTransaction()) own_.emplace(store.begin());
  }
  void commit() {
    if (own_) own_->commit();
  }

 private:
  std::optional<Transaction> own_;
};

}  // namespace placedb::storage
