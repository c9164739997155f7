#pragma once
// Maps made and edited the way other programs would: a small mapped copy, SQL run on it with the
// sqlite3 library, its leaf pages and SQLite's own verdict on it.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "cli_scratch.h"

namespace placedb::testing {

namespace fs = std::filesystem;

inline void sqlExec(const fs::path& map, const std::string& sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(map.c_str(), &db), SQLITE_OK);
  char* error = nullptr;
  EXPECT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &error), SQLITE_OK)
      << (error ? error : "");
  sqlite3_free(error);
  sqlite3_close(db);
}

// The pages of table or index `name` that hold rows (leaf pages), from SQLite's dbstat.
inline std::vector<std::int64_t> leafPages(const fs::path& map, const std::string& name) {
  sqlite3* db = nullptr;
  std::vector<std::int64_t> pages;
  if (sqlite3_open_v2(map.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) return pages;
  sqlite3_stmt* s = nullptr;
  if (sqlite3_prepare_v2(db, "SELECT pageno FROM dbstat WHERE name = ?1 AND pagetype = 'leaf'", -1,
                         &s, nullptr) == SQLITE_OK) {
    sqlite3_bind_text(s, 1, name.c_str(), -1, SQLITE_TRANSIENT);
    while (sqlite3_step(s) == SQLITE_ROW) pages.push_back(sqlite3_column_int64(s, 0));
  }
  sqlite3_finalize(s);
  sqlite3_close(db);
  return pages;
}

// "ok" when SQLite's full integrity check finds nothing wrong, else its first finding.
inline std::string integrityCheck(const fs::path& map) {
  sqlite3* db = nullptr;
  std::string finding = "cannot open";
  if (sqlite3_open_v2(map.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) == SQLITE_OK) {
    sqlite3_stmt* s = nullptr;
    if (sqlite3_prepare_v2(db, "PRAGMA integrity_check(1)", -1, &s, nullptr) == SQLITE_OK &&
        sqlite3_step(s) == SQLITE_ROW)
      finding = reinterpret_cast<const char*>(sqlite3_column_text(s, 0));
    else
      finding = sqlite3_errmsg(db);
    sqlite3_finalize(s);
  }
  sqlite3_close(db);
  return finding;
}

inline fs::path mappedCopy(const fs::path& seq, const fs::path& dir, const std::string& name,
                           const std::vector<std::string>& extra = {}) {
  auto map = dir / name;
  std::vector<std::string> args = {"map", map.string(), (seq / "frames.txt").string(), "-q"};
  args.insert(args.end(), extra.begin(), extra.end());
  auto r = placedb(args, dir);
  EXPECT_EQ(r.exit_code, 0) << describe(r);
  return map;
}

}  // namespace placedb::testing
