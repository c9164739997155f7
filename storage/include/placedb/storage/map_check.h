#pragma once
// A whole-map check for a user who wants to know before a mission: SQLite's own integrity check
// (on a connection that could write, where CHECK constraints are verified too), foreign keys,
// and every row checksum and stored count of schema 8. It never writes: the map and its -wal
// file are left as they were found.
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace placedb::storage {

struct CheckFinding {
  std::string table;    // "words", "engine_state", ... or "sqlite" for integrity_check lines
  std::string row;      // the row's key, empty when the finding is about the table or file
  std::string problem;  // what is wrong, in a few words
};

struct CheckProgress {
  std::string stage;  // "pages", "foreign keys", or the table being summed
  std::int64_t done = 0;
  std::int64_t total = 0;  // rows of the stage, 0 when unknown
};

struct CheckOptions {
  std::size_t max_findings = 100;  // stops listing (not checking) after this many
  std::function<void(const CheckProgress&)> progress;  // every ~20,000 rows and at each stage
  // A further check (the engine's own load checks, say) run when every other check passed,
  // while the check's connection is still open, so that closing it, the last connection, still
  // removes the -wal and -shm files a read-only connection leaves. Returns a problem, or "".
  std::function<std::string()> last_check;
};

struct CheckReport {
  int schema_version = 0;
  bool checksums = true;            // false for a map older than schema 8 (none stored yet)
  bool constraints_checked = true;  // false when only a read-only connection could be opened
  std::map<std::string, std::int64_t> rows_checked;  // per table, rows whose sum was verified
  std::int64_t findings_total = 0;                   // may exceed findings.size()
  std::vector<CheckFinding> findings;
  bool ok() const { return findings_total == 0; }
};

// Throws StorageError: kIo when the file is missing or unreadable, kMapRefused when it is not a
// placedb map this binary can open (not SQLite, another application's, newer schema). Damage is
// reported in the result, not thrown.
// A map on a PostgreSQL server (a URI) gets the checksum, count and value checks; its pages and
// keys are the server's (see schema/SCHEMA.md).
CheckReport checkMap(const std::string& path, const CheckOptions& options = {});
CheckReport checkPgMap(const std::string& uri, const CheckOptions& options = {});

}  // namespace placedb::storage
