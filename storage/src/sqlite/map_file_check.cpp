#include "sqlite/map_file_check.h"

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>
#include <vector>

#include <sys/stat.h>

#include "placedb/storage/map_files.h"
#include "placedb/storage/migrations.h"
#include "sqlite/migrations_apply.h"

namespace placedb::storage::detail {
namespace {

[[noreturn]] void refuse(const std::string& path, const std::string& reason) {
  throw StorageError(ErrorCode::kMapRefused, "map " + path + " refused: " + reason);
}

std::uint32_t bigEndian32(const unsigned char* bytes) {
  return (std::uint32_t{bytes[0]} << 24) | (std::uint32_t{bytes[1]} << 16) |
         (std::uint32_t{bytes[2]} << 8) | std::uint32_t{bytes[3]};
}

// Escapes the characters that would end or change the path part of a file: URI.
std::string uriPath(const std::string& path) {
  std::string absolute = std::filesystem::absolute(path).string();
  std::string escaped;
  for (char c : absolute) {
    if (c == '?' || c == '#' || c == '%') {
      char buffer[4];
      std::snprintf(buffer, sizeof buffer, "%%%02X", static_cast<unsigned char>(c));
      escaped += buffer;
    } else {
      escaped += c;
    }
  }
  return "file:" + escaped;
}

// Reads up to `size` bytes from the start of the file; returns how many were read.
std::size_t readHeader(const std::string& path, unsigned char* out, std::size_t size) {
  sqlite3_vfs* vfs = sqlite3_vfs_find(nullptr);
  std::vector<char> storage(static_cast<std::size_t>(vfs->szOsFile));
  auto* file = reinterpret_cast<sqlite3_file*>(storage.data());
  int out_flags = 0;
  std::string name = path;  // xOpen wants a stable, writable-lifetime name
  int rc =
      vfs->xOpen(vfs, name.c_str(), file, SQLITE_OPEN_READONLY | SQLITE_OPEN_MAIN_DB, &out_flags);
  if (rc != SQLITE_OK) {
    throw StorageError(ErrorCode::kIo, "cannot open " + path + " for reading", rc);
  }
  sqlite3_int64 file_size = 0;
  rc = file->pMethods->xFileSize(file, &file_size);
  std::size_t wanted = std::min<std::size_t>(size, file_size > 0 ? file_size : 0);
  if (rc == SQLITE_OK && wanted > 0) {
    rc = file->pMethods->xRead(file, out, static_cast<int>(wanted), 0);
  }
  file->pMethods->xClose(file);
  if (rc != SQLITE_OK && rc != SQLITE_IOERR_SHORT_READ) {
    throw StorageError(ErrorCode::kIo, "cannot read " + path, rc);
  }
  return wanted;
}

std::string hex32(std::int32_t value) {
  char buffer[16];
  std::snprintf(buffer, sizeof buffer, "0x%08X", static_cast<std::uint32_t>(value));
  return buffer;
}

}  // namespace

std::string resolveMapPath(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code error;
  const auto link = fs::symlink_status(path, error);
  if (fs::is_symlink(link)) {
    const fs::path target = fs::canonical(path, error);
    if (error)
      throw StorageError(ErrorCode::kIo, "map " + path +
                                             " is a symbolic link to a missing file: give the "
                                             "path of the map itself");
    return resolveMapPath(target.string());
  }
  if (!fs::exists(link)) return path;
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode) && st.st_nlink > 1)
    refuse(path, "the file has " + std::to_string(st.st_nlink) +
                     " hard links; SQLite keeps its write-ahead log and placedb its lock under "
                     "each name, so a map must have only one (remove the other links)");
  return path;
}

FileState checkRawFile(const std::string& path) {
  std::error_code error;
  const auto status = std::filesystem::status(path, error);
  if (!std::filesystem::exists(status)) return FileState::kMissing;
  if (!std::filesystem::is_regular_file(status)) refuse(path, "not a regular file");
  const auto size = std::filesystem::file_size(path, error);
  if (error) throw StorageError(ErrorCode::kIo, "cannot read " + path + ": " + error.message());
  if (size == 0) return FileState::kEmpty;

  // Read through SQLite's own VFS: a plain open()/close() of the file would drop the POSIX locks
  // that other SQLite connections of this process hold on it.
  std::array<unsigned char, 100> header{};
  const std::size_t got = readHeader(path, header.data(), header.size());

  static const char kMagic[] = "SQLite format 3";  // 16 bytes with the terminating zero
  if (got < sizeof kMagic || std::memcmp(header.data(), kMagic, sizeof kMagic) != 0) {
    refuse(path, "not a SQLite database (no SQLite header)");
  }
  if (got < header.size())
    refuse(path, "truncated SQLite file (" + std::to_string(size) + " bytes)");

  std::uint32_t page_size = (std::uint32_t{header[16]} << 8) | header[17];
  if (page_size == 1) page_size = 65536;
  if (page_size < 512 || page_size > 65536 || (page_size & (page_size - 1)) != 0) {
    refuse(path, "damaged SQLite header (page size " + std::to_string(page_size) + ")");
  }
  // A checkpoint stopped by a full disk or a file-size limit can leave a partial last page in
  // the main file; the intact write-ahead log still holds every committed page, and SQLite's
  // next checkpoint squares the file. So with a non-empty -wal the file is SQLite's to judge.
  const auto wal_size = std::filesystem::file_size(walFile(path), error);
  const bool has_wal = !error && wal_size > 0;
  if (size % page_size != 0 && !has_wal) {
    refuse(path, "truncated or damaged: " + std::to_string(size) +
                     " bytes is not a whole number of " + std::to_string(page_size) +
                     "-byte pages");
  }
  // The page count in the header is only meaningful when SQLite marked it valid; with a -wal
  // file present the newest pages may live there, so the count is not compared then.
  const std::uint32_t change_counter = bigEndian32(&header[24]);
  const std::uint32_t page_count = bigEndian32(&header[28]);
  const std::uint32_t valid_for = bigEndian32(&header[92]);
  if (!has_wal && page_count != 0 && change_counter == valid_for &&
      std::uint64_t{page_count} * page_size > size) {
    refuse(path, "truncated: the header counts " + std::to_string(page_count) +
                     " pages but the file holds " + std::to_string(size / page_size));
  }
  return FileState::kSqlite;
}

std::unique_ptr<Database> openReadOnly(const std::string& path) {
  const int flags = SQLITE_OPEN_READONLY | SQLITE_OPEN_URI;
  auto db = std::make_unique<Database>(uriPath(path) + "?mode=ro", flags);
  db->setLabel(path);
  try {
    db->queryInt("SELECT count(*) FROM sqlite_master");
    return db;
  } catch (const StorageError& error) {
    const int primary = error.sqliteCode() & 0xff;
    std::error_code ignored;
    const bool can_go_immutable = (primary == SQLITE_READONLY || primary == SQLITE_CANTOPEN) &&
                                  !std::filesystem::exists(walFile(path), ignored);
    if (!can_go_immutable) throw;
  }
  db = std::make_unique<Database>(uriPath(path) + "?mode=ro&immutable=1", flags);
  db->setLabel(path);
  return db;
}

std::unique_ptr<Database> openForInspection(const std::string& path) {
  std::error_code ignored;
  if (std::filesystem::exists(walFile(path), ignored)) return openReadOnly(path);
  auto db = std::make_unique<Database>(uriPath(path) + "?mode=ro&immutable=1",
                                       SQLITE_OPEN_READONLY | SQLITE_OPEN_URI);
  db->setLabel(path);
  return db;
}

MapIdentity inspectIdentity(const std::string& path) {
  auto db = openForInspection(path);
  return readIdentity(*db, path);
}

namespace {

// "table T", "index I" and "column T.C" for every table, index and column of `db` but SQLite's.
std::set<std::string> schemaObjectsIn(Database& db) {
  std::set<std::string> objects;
  Statement list(db.handle(),
                 "SELECT type || ' ' || name FROM sqlite_master "
                 "WHERE type IN ('table', 'index') AND name NOT LIKE 'sqlite_%'");
  while (list.step()) objects.insert(list.columnText(0));
  Statement columns(db.handle(),
                    "SELECT 'column ' || m.name || '.' || c.name FROM sqlite_master AS m, "
                    "pragma_table_info(m.name) AS c "
                    "WHERE m.type = 'table' AND m.name NOT LIKE 'sqlite_%'");
  while (columns.step()) objects.insert(columns.columnText(0));
  return objects;
}

// What a map of schema `version` holds, made once per version by running the embedded
// migrations in memory.
const std::set<std::string>& schemaObjectsOf(int version) {
  static std::mutex mutex;
  static std::map<int, std::set<std::string>> made;
  std::lock_guard<std::mutex> lock(mutex);
  auto it = made.find(version);
  if (it == made.end()) {
    Database blank(":memory:", SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
    applyMigrations(blank, version);
    it = made.emplace(version, schemaObjectsIn(blank)).first;
  }
  return it->second;
}

}  // namespace

std::vector<std::string> schemaMismatches(Database& db, int version) {
  std::vector<std::string> found;
  try {
    const std::set<std::string> present = schemaObjectsIn(db);
    const std::set<std::string>& expected = schemaObjectsOf(version);
    const std::set<std::string>& newest = schemaObjectsOf(currentSchemaVersion());
    for (const auto& object : expected)
      if (!present.count(object)) found.push_back(object + " is missing");
    // A map's own indexes and tables are its owner's business (SCHEMA.md suggests an index in a
    // copy); what a later schema has, or a column in one of placedb's tables, is not.
    for (const auto& object : present) {
      if (expected.count(object)) continue;
      const bool later = newest.count(object) != 0;
      const bool column_of_ours =
          object.rfind("column ", 0) == 0 &&
          expected.count("table " + object.substr(7, object.find('.') - 7)) != 0;
      if (later || column_of_ours)
        found.push_back(object + " is there, which schema " + std::to_string(version) +
                        " does not have");
    }
  } catch (const StorageError& error) {
    if (error.code() == ErrorCode::kMapRefused && error.sqliteCode() != 0)
      found.push_back(error.sqliteMessage());
    else
      throw;
  }
  return found;
}

void checkSchemaObjects(Database& db, const std::string& path, int version) {
  const std::vector<std::string> mismatches = schemaMismatches(db, version);
  if (mismatches.empty()) return;
  refuse(path, version == currentSchemaVersion()
                   ? "damaged: " + mismatches.front()
                   : "its schema version is " + std::to_string(version) +
                         " but its tables are not that schema's (" + mismatches.front() +
                         "): it was changed by hand, and cannot be upgraded");
}

void checkIntegrity(Database& db, const std::string& path) {
  std::string finding;
  try {
    finding = db.queryText("PRAGMA quick_check(1)");
  } catch (const StorageError& error) {
    if (error.code() == ErrorCode::kMapRefused) refuse(path, "damaged: " + error.sqliteMessage());
    throw;
  }
  if (finding != "ok") refuse(path, "damaged (SQLite's quick_check: " + finding + ")");
}

void checkForeignKeys(Database& db, const std::string& path) {
  try {
    Statement check(db.handle(), "PRAGMA foreign_key_check");
    if (check.step())
      refuse(path,
             "damaged: " + check.columnText(0) +
                 (check.isNull(1) ? std::string() : " row " + std::to_string(check.columnInt(1))) +
                 " refers to a missing row of " + check.columnText(2) +
                 " (placedb check lists every such row)");
  } catch (const StorageError& error) {
    if (error.code() == ErrorCode::kMapRefused && error.sqliteCode() != 0)
      refuse(path, "damaged: " + error.sqliteMessage());
    throw;
  }
}

MapIdentity readIdentity(Database& db, const std::string& path) {
  MapIdentity identity;
  try {
    identity.schema_objects = db.queryInt("SELECT count(*) FROM sqlite_master");
    identity.application_id = static_cast<std::int32_t>(db.queryInt("PRAGMA application_id"));
    identity.user_version = static_cast<int>(db.queryInt("PRAGMA user_version"));
  } catch (const StorageError& error) {
    if (error.code() == ErrorCode::kMapRefused) refuse(path, error.sqliteMessage());
    throw;
  }
  return identity;
}

Verdict judgeIdentity(const MapIdentity& identity, const std::string& path, int current_version) {
  if (identity.application_id == kApplicationId) {
    if (identity.user_version > current_version) {
      refuse(path, "its schema version " + std::to_string(identity.user_version) +
                       " is newer than this placedb binary supports (schema version " +
                       std::to_string(current_version) + "); use a newer placedb");
    }
    if (identity.user_version < 1) refuse(path, "placedb mark without a schema version");
    return identity.user_version == current_version ? Verdict::kUpToDate : Verdict::kNeedsMigration;
  }
  if (identity.application_id == 0 && identity.user_version == 0 && identity.schema_objects == 0) {
    return Verdict::kBlankSqlite;
  }
  refuse(path, "a SQLite database but not a placedb map (application_id " +
                   hex32(identity.application_id) + ", expected " + hex32(kApplicationId) + "; " +
                   std::to_string(identity.schema_objects) + " schema objects)");
}

}  // namespace placedb::storage::detail
