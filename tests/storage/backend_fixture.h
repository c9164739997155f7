#pragma once
// The fixture base of the storage tests that run on both backends (records_test.cpp,
// location_words_test.cpp): storage_tests instantiates them on SQLite files, pg_storage_tests
// on PostgreSQL databases. Kept out of storage_test_util.h, which the SQLite-only tests include
// as well: only these tests need the server's helpers.
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <string>

#include "pg_test_server.h"
#include "placedb/storage/map_store.h"
#include "test_paths.h"

namespace placedb::storage::testing {

// The parameter names the backend: "sqlite" (a file) or "postgresql" (a fresh database).
// SetUp opens store_ read-write on an empty map there. A base class, not a helper function:
// PLACEDB_REQUIRE_PG_SERVER skips with GTEST_SKIP, which returns from the function it is in, and
// only a return from SetUp itself keeps the test from running. A derived fixture's SetUp calls
// this one first and returns at once if IsSkipped(), store_ then being null.
class BackendTest : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    if (GetParam() == "postgresql") {
      PLACEDB_REQUIRE_PG_SERVER(server);
      path_ = placedb::testing::freshPgDatabase(server, placedb::testing::pgTestDatabaseName());
    } else {
      // The suite is "Instantiation/Fixture"; the folder is named after the fixture and test.
      const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
      const std::string suite = info->test_suite_name();
      dir_ = placedb::testing::scratchDir(suite.substr(suite.rfind('/') + 1) + "_" + info->name());
      path_ = (dir_ / "map.db").string();
    }
    store_ = openMapStore(path_, OpenMode::kReadWrite);
  }

  std::filesystem::path dir_;  // the SQLite file's folder; empty on PostgreSQL
  std::string path_;           // the map as openMapStore takes it: a file's path or a URI
  std::unique_ptr<MapStore> store_;
};

}  // namespace placedb::storage::testing
