#include <filesystem>

#include "placedb/storage/migrations.h"
#include "sqlite/migrations_apply.h"
#include "sqlite/sqlite_checksums.h"
#include "sqlite/sqlite_location_rows.h"

namespace placedb::storage {

namespace detail {

void applyMigrations(Database& db, int target_version) {
  db.exec("PRAGMA foreign_keys = OFF");
  for (const Migration& migration : migrations()) {
    if (migration.version > target_version) break;
    try {
      db.exec("BEGIN IMMEDIATE");
    } catch (const StorageError& error) {
      if (error.code() != ErrorCode::kMapBusy) throw;
      throw StorageError(ErrorCode::kMapBusy,
                         "map " + db.label() + " is busy: another writer holds it, so migration " +
                             migration.name + " cannot run",
                         error.sqliteCode(), error.sqliteMessage(), error.sql());
    }
    try {
      const int found_version = static_cast<int>(db.queryInt("PRAGMA user_version"));
      if (found_version < migration.version) {
        try {
          db.exec(migration.sql);
          if (migration.version == kChecksumSchemaVersion) fillChecksums(db);
          if (migration.version == kLocationRowsSchemaVersion) fillLocationRows(db);
        } catch (const StorageError& error) {
          if (error.code() == ErrorCode::kDiskFull || error.code() == ErrorCode::kMapBusy ||
              error.code() == ErrorCode::kIo)
            throw;
          // The upgrade of a map whose tables do not match its schema version (a damaged
          // user_version) fails inside the migration's SQL: one line naming the map and the
          // step, not the whole script.
          throw StorageError(ErrorCode::kMapRefused,
                             "map " + db.label() + " cannot be upgraded from schema " +
                                 std::to_string(found_version) + " (migration " + migration.name +
                                 "): " + error.sqliteMessage() +
                                 "; its tables do not match its schema version",
                             error.sqliteCode(), error.sqliteMessage());
        }
        if (db.queryInt("SELECT count(*) FROM pragma_foreign_key_check") != 0) {
          throw StorageError(ErrorCode::kInternal, std::string("migration ") + migration.name +
                                                       " leaves foreign keys violated");
        }
        db.exec("PRAGMA user_version = " + std::to_string(migration.version));
        db.exec("PRAGMA application_id = " + std::to_string(kApplicationId));
      }
      db.exec("COMMIT");
    } catch (...) {
      sqlite3_exec(db.handle(), "ROLLBACK", nullptr, nullptr, nullptr);
      db.exec("PRAGMA foreign_keys = ON");
      throw;
    }
  }
  db.exec("PRAGMA foreign_keys = ON");
}

}  // namespace detail

void buildMapAtVersion(const std::string& path, int version) {
  if (version < 1 || version > currentSchemaVersion()) {
    throw Error(ErrorCode::kInvalidArgument,
                "no schema version " + std::to_string(version) + " to build");
  }
  std::error_code error;
  if (std::filesystem::exists(path, error) && std::filesystem::file_size(path, error) != 0) {
    throw Error(ErrorCode::kInvalidArgument, "buildMapAtVersion: " + path + " is not empty");
  }
  detail::Database db(path, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
  db.queryText("PRAGMA journal_mode = WAL");
  detail::applyMigrations(db, version);
}

}  // namespace placedb::storage
