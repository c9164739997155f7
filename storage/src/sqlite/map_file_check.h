#pragma once
// The checks that decide whether a file may be opened as a placedb map. None of them writes:
// they read the raw header and then look through a read-only connection.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sqlite/database.h"

namespace placedb::storage::detail {

enum class FileState { kMissing, kEmpty, kSqlite };

// The one name SQLite and the writer lock use for the map at `path`. SQLite keeps the write-ahead
// log and the lock under the name it is given, so two names for one file would give two logs
// and two locks: symbolic links are resolved (a link to a missing file is kIo: it would create
// the map somewhere else), and a file with more than one hard link is kMapRefused.
std::string resolveMapPath(const std::string& path);

// Reads the first 100 bytes and the size; throws kMapRefused for files that are not SQLite or
// visibly truncated, kIo when the file cannot be read.
FileState checkRawFile(const std::string& path);

struct MapIdentity {
  std::int32_t application_id = 0;
  int user_version = 0;
  std::int64_t schema_objects = 0;  // rows of sqlite_master
};

// A read-only connection (mode=ro). When the map is in WAL mode, has no -wal file, and its folder
// is not writable, SQLite cannot create the -shm file and refuses; the map then opens immutable,
// which is safe because without a -wal file the main file holds every committed frame.
std::unique_ptr<Database> openReadOnly(const std::string& path);

// Reads the identity; a file SQLite rejects becomes kMapRefused naming the path.
MapIdentity readIdentity(Database& db, const std::string& path);

// A read-only connection that creates no file next to the map (immutable when there is no -wal
// file, whose absence means the main file holds every committed page).
std::unique_ptr<Database> openForInspection(const std::string& path);

// Reads the identity without creating any file next to the map.
MapIdentity inspectIdentity(const std::string& path);

// How the map's tables, indexes and columns differ from those of schema `version`: one line per
// difference ("index locations_by_tier is missing", "column locations.x is there, which schema
// 13 does not have"). A map's own extra tables and indexes are not differences, unless a later
// schema has them. Empty when the map is that schema's.
std::vector<std::string> schemaMismatches(Database& db, int version);

// Throws kMapRefused naming the first difference of schemaMismatches() (the map was edited by
// hand or damaged, or its user_version changed: the engine could not run on it, and an upgrade
// would fail in the middle).
void checkSchemaObjects(Database& db, const std::string& path, int version);

// PRAGMA quick_check: reads every page of the file (b-tree structure, record formats, index
// order and counts; not UNIQUE/foreign-key contents), so its cost grows with the file. Throws
// kMapRefused with SQLite's first finding when the file is malformed.
void checkIntegrity(Database& db, const std::string& path);

// PRAGMA foreign_key_check: a row naming one that is not there (a locations or frames row
// deleted with foreign keys off). Throws kMapRefused naming the first such row. It looks every
// reference up, so it costs about a page check's time; it runs with it.
void checkForeignKeys(Database& db, const std::string& path);

// Every row sum (schema 8) and stored count, as placedb check verifies them: what the page check
// adds on a map small enough for it, so that a row damaged in long-term memory is refused at
// open, not when a later frame reads it. Throws kMapRefused naming the first damaged row.
// (map_check.cpp)
void checkRowSums(Database& db, const std::string& path);

// What to do with a file whose identity is known.
enum class Verdict { kUpToDate, kNeedsMigration, kBlankSqlite };
// Throws kMapRefused with the reason when the file is not a placedb map this binary can open.
Verdict judgeIdentity(const MapIdentity& identity, const std::string& path, int current_version);

}  // namespace placedb::storage::detail
