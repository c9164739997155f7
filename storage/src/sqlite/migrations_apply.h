#pragma once
// Applies the embedded migrations to an open read-write connection.
#include "sqlite/database.h"

namespace placedb::storage::detail {

// Brings the map to `target_version`, one transaction per migration. Each transaction re-reads
// PRAGMA user_version, so a migration another process already applied is skipped. Foreign keys
// are off while a script runs (so later scripts may rebuild tables) and checked before commit.
void applyMigrations(Database& db, int target_version);

}  // namespace placedb::storage::detail
