#pragma once
// What placedb check finds, whichever backend holds the map: the report both checks fill and the
// options they read (map_check.h runs the one the map's name picks).
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

}  // namespace placedb::storage
