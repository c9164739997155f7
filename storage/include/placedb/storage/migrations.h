#pragma once
// The schema migrations embedded from migrations/*.sql, and the functions that apply them.
#include <cstdint>
#include <string>
#include <vector>

namespace placedb::storage {

// PRAGMA application_id of every placedb map: 'PLDB'.
constexpr std::int32_t kApplicationId = 0x504C4442;

struct Migration {
  int version;       // the schema version after this script, 1, 2, ...
  const char* name;  // file name, e.g. "0001_init.sql"
  const char* sql;
};

// Every migration, ordered by version (generated at build time).
const std::vector<Migration>& migrations();
// PostgreSQL's, from migrations/pg/: they begin at the version its maps start from (9) and
// share every number with SQLite's, so both backends report one schema version.
const std::vector<Migration>& pgMigrations();

// The schema version this binary writes: the highest migration.
int currentSchemaVersion();

// Creates a map file at `path` (which must not exist or be empty) holding schema `version`,
// by applying migrations 1..version only. For tests that upgrade from each older version.
void buildMapAtVersion(const std::string& path, int version);

}  // namespace placedb::storage
