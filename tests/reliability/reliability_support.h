#pragma once
// Helpers of the reliability tests: the child mapper, SQLite's own integrity check, file bytes and
// the per-frame results a map file holds.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "child_process.h"
#include "file_bytes.h"
#include "placedb/storage/map_files.h"
#include "placedb/storage/sqlite_map_store.h"
#include "test_paths.h"

namespace placedb::testing {

inline std::string mapperPath() { return PLACEDB_CRASH_MAPPER; }

inline std::vector<std::string> mapperArgs(const std::filesystem::path& map,
                                           std::vector<std::string> extra = {}) {
  std::vector<std::string> args{mapperPath(), map.string()};
  args.insert(args.end(), extra.begin(), extra.end());
  return args;
}

inline void removeMapFiles(const std::filesystem::path& p) { storage::removeMap(p.string()); }

// "ok" when SQLite finds nothing wrong, else its report (or the open error).
inline std::string integrityCheck(const std::filesystem::path& map) {
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(map.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
    std::string message = sqlite3_errmsg(db);
    sqlite3_close(db);
    return "open failed: " + message;
  }
  std::string report;
  const int rc = sqlite3_exec(
      db, "PRAGMA integrity_check",
      [](void* out, int, char** values, char**) {
        auto& text = *static_cast<std::string*>(out);
        text += (text.empty() ? "" : "; ") + std::string(values[0] ? values[0] : "NULL");
        return 0;
      },
      &report, nullptr);
  // A check that could not run says why, rather than an empty report that reads as no finding.
  if (rc != SQLITE_OK)
    report += (report.empty() ? "" : "; ") + std::string("check failed: ") + sqlite3_errmsg(db) +
              " (extended code " + std::to_string(sqlite3_extended_errcode(db)) + ")";
  sqlite3_close(db);
  return report;
}

// What a frame left in the map: enough to compare two runs frame by frame.
struct StoredFrame {
  std::int64_t frame_id = 0;
  int outcome = 0;
  std::int64_t location = 0;
  std::int64_t hypothesis = 0;
  double posterior = 0, score = 0;
  bool accepted = false;
};

// By source index, over every session of the map.
// The file's schema version (PRAGMA user_version): below the current one when a writer was
// killed while making the map, before its last migration (each commits on its own) and so
// before any frame.
inline int schemaVersion(const std::filesystem::path& map) {
  sqlite3* db = nullptr;
  int count = -1;
  if (sqlite3_open_v2(map.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) == SQLITE_OK)
    sqlite3_exec(
        db, "PRAGMA user_version",
        [](void* out, int, char** values, char**) {
          *static_cast<int*>(out) = values[0] ? std::atoi(values[0]) : -1;
          return 0;
        },
        &count, nullptr);
  sqlite3_close(db);
  return count;
}

inline std::map<std::int64_t, StoredFrame> storedFrames(const std::filesystem::path& map) {
  std::map<std::int64_t, StoredFrame> out;
  // A map not fully made holds no frame (and a read-only open refuses it).
  if (schemaVersion(map) < storage::MapStore::currentSchemaVersion()) return out;
  storage::SqliteMapStore store(map.string(), storage::OpenMode::kReadOnly);
  for (const auto& session : store.sessions())
    for (const auto& f : store.frames(session.id)) {
      StoredFrame s;
      s.frame_id = f.id;
      s.outcome = static_cast<int>(f.outcome);
      s.location = f.location_id.value_or(0);
      if (auto h = store.hypothesis(f.id)) {
        s.hypothesis = h->best_location_id.value_or(0);
        s.posterior = h->posterior;
        s.score = h->loop_probability;
        s.accepted = h->accepted;
      }
      out[f.source_index] = s;
    }
  return out;
}

// Runs the mapper to its end; the lines it printed. Fails the test on an error line.
inline std::vector<std::string> runMapper(const std::filesystem::path& map,
                                          std::vector<std::string> extra = {}) {
  ChildProcess child(mapperArgs(map, std::move(extra)));
  std::vector<std::string> lines;
  while (auto line = child.readLine(60000)) lines.push_back(*line);
  const int status = child.wait();
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
      << "mapper failed: " << (lines.empty() ? "no output" : lines.back());
  return lines;
}

}  // namespace placedb::testing
