// Every refusal of `placedb` is one error line and its documented exit status.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "cli_test_support.h"
#include "placedb/options.h"
#include "placedb/storage/sqlite_map_store.h"

namespace placedb::testing {
namespace {

namespace fs = std::filesystem;

// A folder of two small random images: a valid SOURCE that never reaches the engine here.
fs::path tinySource(const fs::path& dir) {
  fs::create_directories(dir / "images");
  for (int i = 0; i < 2; ++i) {
    cv::Mat image(64, 80, CV_8UC1);
    cv::randu(image, 0, 255);
    cv::imwrite((dir / "images" / (std::to_string(i) + ".png")).string(), image);
  }
  return dir / "images";
}

TEST(CliUsage, HelpTeachesEverySubcommand) {
  auto dir = scratchDir("CliUsage_help");
  auto top = placedb({"--help"}, dir);
  EXPECT_EQ(top.exit_code, 0);
  EXPECT_NE(top.out.find("Exit status"), std::string::npos) << top.out;
  EXPECT_NE(top.out.find("map busy"), std::string::npos);
  for (const char* sub : {"map", "query", "info", "vocab", "eval", "demo", "export", "settings"}) {
    auto help = placedb({sub, "--help"}, dir);
    EXPECT_EQ(help.exit_code, 0) << sub;
    EXPECT_NE(help.out.find("Example"), std::string::npos) << sub << ":\n" << help.out;
  }
}

TEST(CliUsage, UsageErrorsExitTwo) {
  auto dir = scratchDir("CliUsage_errors");
  expectCleanError(placedb({}, dir), 2);
  expectCleanError(placedb({"frobnicate"}, dir), 2);
  expectCleanError(placedb({"map", "only-a-map.placedb"}, dir), 2);
  expectCleanError(placedb({"map", "m", "s", "--stop-after", "zero"}, dir), 2);
}

TEST(CliUsage, MapWithoutArgumentsPointsAtItsHelp) {
  auto dir = scratchDir("CliUsage_map_bare");
  auto bare = placedb({"map"}, dir);
  expectCleanError(bare, 2, "placedb map --help");
}

TEST(CliUsage, SettingsAsJsonWithRtabmapAliases) {
  auto dir = scratchDir("CliUsage_settings_json");
  auto listed = placedb({"settings", "--json"}, dir);
  ASSERT_EQ(listed.exit_code, 0) << describe(listed);
  const nlohmann::json rows = nlohmann::json::parse(listed.out);
  ASSERT_EQ(rows.size(), Options::catalogue().size());
  bool t_loop_seen = false;
  for (const auto& row : rows) {
    EXPECT_TRUE(row.contains("default") && row.contains("valid") && row.contains("description"));
    if (row["key"] == "t_loop") {
      t_loop_seen = true;
      EXPECT_EQ(row["aliases"], nlohmann::json::array({"Rtabmap/LoopThr"}));
    }
  }
  EXPECT_TRUE(t_loop_seen);
  auto text = placedb({"settings"}, dir);
  EXPECT_NE(text.out.find("Rtabmap/LoopThr"), std::string::npos) << text.out;
}

TEST(CliErrors, MissingSourceIsIo) {
  auto dir = scratchDir("CliErrors_source");
  expectCleanError(placedb({"map", (dir / "m.placedb").string(), (dir / "nope").string()}, dir), 3,
                   "nope");
  EXPECT_FALSE(fs::exists(dir / "m.placedb")) << "a refused run must not create the map";
}

TEST(CliErrors, BadSettingsAreRefusedWithTheValidOnes) {
  auto dir = scratchDir("CliErrors_settings");
  auto source = tinySource(dir).string();
  auto map = (dir / "m.placedb").string();
  expectCleanError(placedb({"map", map, source, "--set", "no_such_key=1"}, dir), 2, "t_loop");
  expectCleanError(placedb({"map", map, source, "--set", "t_loop=banana"}, dir), 2, "t_loop");
  expectCleanError(placedb({"map", map, source, "--set", "t_loop"}, dir), 2);
  expectCleanError(placedb({"map", map, source, "--preset", "fastest"}, dir), 2, "paper");
  expectCleanError(placedb({"map", map, source, "--config", (dir / "none.conf").string()}, dir), 3);
  EXPECT_FALSE(fs::exists(map));
}

TEST(CliErrors, RandomBytesMapIsRefused) {
  auto dir = scratchDir("CliErrors_random_map");
  auto source = tinySource(dir).string();
  std::mt19937 random(3);
  std::string bytes(8192, '\0');
  for (char& c : bytes) c = static_cast<char>(random() & 0xFF);
  std::ofstream(dir / "m.placedb", std::ios::binary) << bytes;
  expectCleanError(placedb({"map", (dir / "m.placedb").string(), source}, dir), 4);
  expectCleanError(placedb({"info", (dir / "m.placedb").string()}, dir), 4);
  // Left untouched.
  EXPECT_EQ(readBytes(dir / "m.placedb"), bytes);
}

TEST(CliErrors, ForeignSqliteFileIsRefused) {
  auto dir = scratchDir("CliErrors_foreign");
  auto source = tinySource(dir).string();
  auto path = (dir / "other.db").string();
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "CREATE TABLE people (name TEXT); INSERT INTO people VALUES ('x');",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  expectCleanError(placedb({"map", path, source}, dir), 4);
  expectCleanError(placedb({"info", path}, dir), 4);
  expectCleanError(placedb({"query", path, source + "/0.png"}, dir), 4);
}

TEST(CliErrors, MapHeldByAnotherWriterIsBusy) {
  auto dir = scratchDir("CliErrors_busy");
  auto source = tinySource(dir).string();
  auto path = (dir / "m.placedb").string();
  storage::OpenOptions options;
  storage::SqliteMapStore writer(path, storage::OpenMode::kReadWrite, options);
  expectCleanError(placedb({"map", path, source}, dir), 5);
}

TEST(CliErrors, MissingFilesForOtherCommands) {
  auto dir = scratchDir("CliErrors_missing");
  expectCleanError(placedb({"info", (dir / "none.placedb").string()}, dir), 3);
  expectCleanError(placedb({"query", (dir / "none.placedb").string(), "x.png"}, dir), 3);
  expectCleanError(placedb({"eval", (dir / "none.csv").string(), (dir / "gt.txt").string()}, dir),
                   3);
  std::ofstream(dir / "bad.csv") << "frame,score\n0,1\n";
  std::ofstream(dir / "gt.txt") << "1 0\n";
  expectCleanError(placedb({"eval", (dir / "bad.csv").string(), (dir / "gt.txt").string()}, dir), 2,
                   "candidate_frames");
}

}  // namespace
}  // namespace placedb::testing
