// Faults around `placedb`: a second name for the map (hard or symbolic link), damaged pages and
// missing tables, a disk that fills up under the log or an export, crafted vocabulary files, and
// SIGHUP. Each gives its documented exit status and leaves no partial file behind.
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>

#include "cli_map_edits.h"
#include "cli_scratch.h"
#include "placedb/storage/migrations.h"
#include "placedb/storage/sqlite_map_store.h"
#include "vocabulary/vocabulary_file.h"

namespace placedb::testing {
namespace {

namespace fs = std::filesystem;

TEST(CliFaults, SecondNameForTheMapIsRefusedOrResolved) {
  auto seq = smallSequence(8);
  auto dir = scratchDir("CliFaults_links");
  auto a = mappedCopy(seq, dir, "a.placedb", {"--stop-after", "4"});
  ASSERT_EQ(::link(a.c_str(), (dir / "b.placedb").c_str()), 0);
  const std::string before = bytesOf(a);
  // Each name would get its own write-ahead log and lock: both names are refused.
  for (const char* name : {"a.placedb", "b.placedb"}) {
    expectCleanError(placedb({"map", (dir / name).string(), (seq / "frames.txt").string()}, dir), 4,
                     "hard links");
    EXPECT_TRUE(bytesOf(a) == before);
  }
  fs::remove(dir / "b.placedb");

  // A symbolic link is the map it points to: read, resumed and locked as that file.
  fs::create_symlink(a, dir / "link.placedb");
  auto info = placedb({"info", (dir / "link.placedb").string(), "--json"}, dir);
  ASSERT_EQ(info.exit_code, 0) << describe(info);
  EXPECT_EQ(nlohmann::json::parse(info.out)["frames"], 4);
  auto resumed =
      placedb({"map", (dir / "link.placedb").string(), (seq / "frames.txt").string(), "-q"}, dir);
  ASSERT_EQ(resumed.exit_code, 0) << describe(resumed);
  EXPECT_TRUE(fs::is_symlink(dir / "link.placedb"));
  EXPECT_FALSE(fs::exists(dir / "link.placedb-wal"));
  storage::SqliteMapStore store(a.string(), storage::OpenMode::kReadOnly);
  EXPECT_EQ(store.frameCount(), 8);

  // A link to nothing is not followed to create a map elsewhere.
  fs::create_symlink(dir / "nowhere" / "x.placedb", dir / "dangling.placedb");
  expectCleanError(
      placedb({"map", (dir / "dangling.placedb").string(), (seq / "frames.txt").string()}, dir), 3,
      "dangling.placedb");
  EXPECT_FALSE(fs::exists(dir / "nowhere"));
}

TEST(CliFaults, DamagedPagesAreRefusedBeforeAnyWrite) {
  auto seq = smallSequence(12);
  auto dir = scratchDir("CliFaults_damaged");
  auto good = mappedCopy(seq, dir, "good.placedb", {"--stop-after", "8"});
  for (const char* object : {"words", "links", "hypotheses", "links_by_b"}) {
    auto pages = leafPages(good, object);
    ASSERT_FALSE(pages.empty()) << object << ": no leaf page (dbstat missing?)";
    auto map = dir / (std::string(object) + ".placedb");
    fs::copy_file(good, map, fs::copy_options::overwrite_existing);
    {
      std::fstream f(map, std::ios::in | std::ios::out | std::ios::binary);
      // The cell pointers just past the 8-byte leaf header: SQLite can no longer find the rows.
      f.seekp((pages.back() - 1) * 4096 + 8);
      const std::string junk(64, '\x5a');
      f.write(junk.data(), static_cast<std::streamsize>(junk.size()));
    }
    ASSERT_NE(integrityCheck(map), "ok") << object;
    const std::string before = bytesOf(map);
    auto r = placedb({"map", map.string(), (seq / "frames.txt").string(), "-q"}, dir);
    EXPECT_EQ(r.exit_code, 4) << object << ": " << describe(r);
    EXPECT_NE(r.err.find(map.string()), std::string::npos) << r.err;
    EXPECT_TRUE(bytesOf(map) == before) << object;
  }
}

// A value its CHECK constraint forbids (written with the constraints switched off): SQLite's
// quick_check names it only on a connection that could write, so that is where the map looks.
TEST(CliFaults, CheckConstraintViolationIsRefusedBeforeAnyWrite) {
  auto seq = smallSequence(8);
  auto dir = scratchDir("CliFaults_check_constraint");
  auto map = mappedCopy(seq, dir, "m.placedb", {"--stop-after", "5"});
  sqlExec(map,
          "PRAGMA ignore_check_constraints = 1; "
          "UPDATE locations SET tier = 7 WHERE id = (SELECT min(id) FROM locations)");
  const std::string before = bytesOf(map);
  auto r = placedb({"map", map.string(), (seq / "frames.txt").string(), "-q"}, dir);
  EXPECT_EQ(r.exit_code, 4) << describe(r);
  EXPECT_NE(r.err.find(map.string()), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("CHECK constraint failed in locations"), std::string::npos) << r.err;
  EXPECT_TRUE(bytesOf(map) == before);
}

// Values SQLite cannot judge: the engine's own state, wrong in ways no page check sees. Each is
// refused before any write (exit 4, naming the map and what is wrong), the map byte-identical.
// The counters are rewritten through MapStore, with a valid checksum, so the value checks are
// what refuses them (an edit by SQL alone fails its checksum first: RowChecksums covers that).
TEST(CliFaults, DamagedEngineValuesAreRefusedBeforeAnyWrite) {
  auto seq = smallSequence(12);
  auto dir = scratchDir("CliFaults_values");
  auto good = mappedCopy(seq, dir, "good.placedb", {"--stop-after", "8"});
  const auto setCounter = [](const fs::path& map, const char* name, long long value) {
    storage::SqliteMapStore store(map.string(), storage::OpenMode::kReadWrite);
    auto counters = nlohmann::json::parse(*store.getStateText("engine.counters"));
    counters[name] = value;
    store.putState("engine.counters", counters.dump());
  };
  const std::vector<std::pair<std::function<void(const fs::path&)>, std::string>> damage = {
      {[&](const fs::path& map) { setCounter(map, "next_location_id", -5); }, "next_location_id"},
      {[&](const fs::path& map) { setCounter(map, "next_frame_id", 0); }, "next_frame_id"},
      {[](const fs::path& map) {
         sqlExec(map,
                 "UPDATE locations SET weight = -3 WHERE id = (SELECT min(id) FROM locations)");
       },
       "locations row"},  // its checksum (schema 15) finds it before its value is judged
      {[](const fs::path& map) {
         sqlExec(map,
                 "UPDATE filter_posterior SET probability = -1e999 "
                 "WHERE location_id = (SELECT min(location_id) FROM filter_posterior)");
       },
       "filter_posterior row"},
  };
  int n = 0;
  for (const auto& [apply, names] : damage) {
    auto map = dir / ("v" + std::to_string(n++) + ".placedb");
    fs::copy_file(good, map, fs::copy_options::overwrite_existing);
    apply(map);
    const std::string before = bytesOf(map);
    auto r = placedb({"map", map.string(), (seq / "frames.txt").string(), "-q"}, dir);
    EXPECT_EQ(r.exit_code, 4) << names << ": " << describe(r);
    EXPECT_NE(r.err.find(map.string()), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(names), std::string::npos) << r.err;
    EXPECT_TRUE(bytesOf(map) == before) << names;
  }
}

// What check reports, map and query refuse (exit 4, naming table and row) and leave the file
// byte-identical; before, map wrote on a map check called damaged, query answered on a tier of 7,
// and counters behind the rows (their sum forged) passed check and failed map after it wrote.
TEST(CliFaults, WhatCheckReportsMapAndQueryRefuseBeforeAnyWrite) {
  auto seq = smallSequence(12);
  auto dir = scratchDir("CliFaults_check_agrees");
  auto good = mappedCopy(seq, dir, "good.placedb", {"--stop-after", "8"});
  const auto forgeCounter = [](const fs::path& map) {
    storage::SqliteMapStore store(map.string(), storage::OpenMode::kReadWrite);
    auto counters = nlohmann::json::parse(*store.getStateText("engine.counters"));
    counters["next_frame_id"] = 3;  // below the frames there are, its sum written as placedb does
    store.putState("engine.counters", counters.dump());
  };
  const std::vector<std::pair<std::function<void(const fs::path&)>, std::string>> damage = {
      {[](const fs::path& map) {
         sqlExec(map, "DELETE FROM locations WHERE id = (SELECT max(id) FROM locations)");
       },
       "refers to a missing row of locations"},
      {[](const fs::path& map) { sqlExec(map, "DELETE FROM frames WHERE id = 4"); },
       "refers to a missing row of frames"},
      {[](const fs::path& map) {
         sqlExec(map,
                 "PRAGMA ignore_check_constraints = 1; UPDATE locations SET tier = 7 "
                 "WHERE id = (SELECT min(id) FROM locations)");
       },
       "locations"},
      {forgeCounter, "next_frame_id"},
      {[](const fs::path& map) {
         sqlExec(map,
                 "DELETE FROM engine_state WHERE key = 'keypoint_descriptors/' || "
                 "(SELECT min(id) FROM locations)");
       },
       "keypoint_descriptors"},
  };
  int n = 0;
  for (const auto& [apply, names] : damage) {
    auto map = dir / ("d" + std::to_string(n++) + ".placedb");
    fs::copy_file(good, map, fs::copy_options::overwrite_existing);
    apply(map);
    const std::string before = bytesOf(map);
    expectCleanError(placedb({"check", map.string(), "-q"}, dir), 4, map.string());
    auto mapped = placedb({"map", map.string(), (seq / "frames.txt").string(), "-q"}, dir);
    expectCleanError(mapped, 4, names);
    expectCleanError(
        placedb({"query", map.string(), (seq / "images" / "000001.png").string()}, dir), 4,
        map.string());
    EXPECT_TRUE(bytesOf(map) == before) << names;
  }
}

// A schema version one below the tables' (a damaged user_version): the upgrade fails on the
// first change the tables already have. One line naming the map, exit 4, the map unchanged.
TEST(CliFaults, SchemaVersionBelowTheTablesIsOneLineRefusal) {
  auto seq = smallSequence(6);
  auto dir = scratchDir("CliFaults_user_version");
  auto map = mappedCopy(seq, dir, "m.placedb", {"--stop-after", "3"});
  // The schema before the last one that changed a file's tables: schemas 16 to 19 changed the
  // server's alone (migrations/0016-0019), so a file marked 15 to 18 is one to upgrade, not one
  // below its tables.
  constexpr int kBelow = 14;
  sqlExec(map, "PRAGMA user_version = " + std::to_string(kBelow));
  const std::string before = bytesOf(map);
  auto r = placedb({"map", map.string(), (seq / "frames.txt").string(), "-q"}, dir);
  expectCleanError(r, 4, map.string());
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_EQ(r.err.find("in statement"), std::string::npos) << r.err;
  EXPECT_TRUE(bytesOf(map) == before);
  // `check` reports what `map` refuses (it said "sound"), and `query` refuses it too.
  auto check = placedb({"check", map.string(), "-q"}, dir);
  expectCleanError(check, 4, "schema");
  EXPECT_NE(check.out.find("the map says schema " + std::to_string(kBelow)), std::string::npos)
      << check.out;
  expectCleanError(placedb({"query", map.string(), (seq / "images" / "000001.png").string()}, dir),
                   4, map.string());
  EXPECT_TRUE(bytesOf(map) == before);
}

TEST(CliFaults, MissingTablesAreRefusedNotStorageFailures) {
  auto seq = smallSequence(6);
  auto dir = scratchDir("CliFaults_tables");
  auto good = mappedCopy(seq, dir, "good.placedb", {"--stop-after", "3"});
  for (const char* table : {"links", "kd_nodes", "engine_state", "filter_posterior"}) {
    auto map = dir / (std::string(table) + ".placedb");
    fs::copy_file(good, map, fs::copy_options::overwrite_existing);
    sqlExec(map, std::string("DROP TABLE ") + table);
    const std::string before = bytesOf(map);
    expectCleanError(placedb({"info", map.string()}, dir), 4, table);
    expectCleanError(placedb({"map", map.string(), (seq / "frames.txt").string()}, dir), 4, table);
    EXPECT_TRUE(bytesOf(map) == before) << table;
  }
}

TEST(CliFaults, FullDiskUnderTheLogIsDiskFullWithWholeRows) {
  auto seq = smallSequence(40);
  auto dir = scratchDir("CliFaults_log_full");
  TinyDisk disk(dir / "disk", "4k");
  if (!disk.mounted()) GTEST_SKIP() << "cannot mount a tmpfs here (needs CAP_SYS_ADMIN)";
  auto map = (dir / "m.placedb").string(), log = (dir / "disk" / "run.csv").string();
  auto source = (seq / "frames.txt").string();
  auto full = placedb({"map", map, source, "--log", log, "-q"}, dir);
  EXPECT_EQ(full.exit_code, 7) << describe(full);
  EXPECT_NE(full.err.find(log), std::string::npos) << full.err;
  expectWholeRows(log);
  const auto rows = lines(bytesOf(log)).size() - 1;
  EXPECT_GT(rows, 0u);
  EXPECT_LT(rows, 40u);

  // With room again the session resumes; the log keeps whole rows only, and gets back the row
  // of the frame that filled the disk (the map has that frame): every frame once.
  ASSERT_TRUE(disk.resize("1m"));
  auto rest = placedb({"map", map, source, "--log", log, "-q"}, dir);
  ASSERT_EQ(rest.exit_code, 0) << describe(rest);
  expectWholeRows(log);
  storage::SqliteMapStore store(map, storage::OpenMode::kReadOnly);
  EXPECT_EQ(store.frameCount(), 40);
  const cli::CsvTable table = cli::readCsv(log);
  ASSERT_EQ(table.rows.size(), 40u);
  for (std::size_t i = 0; i < table.rows.size(); ++i)
    EXPECT_EQ(table.cell(i, table.column("frame")), std::to_string(i));
}

TEST(CliFaults, FullDiskUnderAVocabularyExportIsDiskFullWithNoFileLeft) {
  auto seq = smallSequence(10);
  auto dir = scratchDir("CliFaults_export_full");
  auto map = mappedCopy(seq, dir, "m.placedb");
  for (bool text : {false, true}) {
    const auto out = dir / (text ? "words.txt" : "words.pvoc");
    // ulimit -f counts 1024-byte blocks: 8 KiB is less than the words of 10 frames.
    std::string command = "ulimit -f 8; exec " + std::string(PLACEDB_CLI_BINARY) +
                          " vocab export " + map.string() + " " + out.string() +
                          (text ? " --text" : "");
    auto r = run({"/bin/sh", "-c", command}, dir);
    EXPECT_EQ(r.exit_code, 7) << describe(r);
    EXPECT_EQ(r.err.rfind("placedb: error: ", 0), 0u) << r.err;
    EXPECT_FALSE(fs::exists(out)) << out;
  }
  for (const auto& entry : fs::directory_iterator(dir))
    EXPECT_EQ(entry.path().filename().string().find(".partial"), std::string::npos) << entry.path();
}

TEST(CliFaults, CraftedVocabularyFilesWithValidChecksumsAreRefused) {
  auto dir = scratchDir("CliFaults_vocab");
  auto write = [&](const std::string& name, std::vector<std::int64_t> ids, float value) {
    vocab::VocabularyData data;
    data.extractor = "surf-64";
    data.dim = 64;
    data.ids = ids;
    data.created_frames.assign(ids.size(), -1);
    data.descriptors = cv::Mat(static_cast<int>(ids.size()), 64, CV_32F, cv::Scalar(0.1));
    data.descriptors.at<float>(0, 5) = value;
    vocab::writeVocabularyFile(dir / name, data);
    std::ofstream text(dir / (name + ".txt"));
    for (std::size_t i = 0; i < ids.size(); ++i) {
      text << ids[i];
      for (int d = 0; d < 64; ++d) text << ' ' << (i == 0 && d == 5 ? "0.5" : "0.1");
      text << '\n';
    }
  };
  write("nan.pvoc", {0, 1, 2}, std::numeric_limits<float>::quiet_NaN());
  write("inf.pvoc", {0, 1, 2}, std::numeric_limits<float>::infinity());
  write("negative.pvoc", {-4, 1, 2}, 0.5f);
  write("twice.pvoc", {0, 1, 1}, 0.5f);
  for (const char* file : {"nan.pvoc", "inf.pvoc", "negative.pvoc", "twice.pvoc"}) {
    auto map = dir / (std::string(file) + ".placedb");
    expectCleanError(
        placedb({"vocab", "import", (dir / file).string(), map.string(), "--mode", "seed"}, dir), 8,
        file);
    EXPECT_FALSE(fs::exists(map)) << file;
  }
  for (const char* file : {"negative.pvoc.txt", "twice.pvoc.txt"}) {
    auto map = dir / (std::string(file) + ".placedb");
    expectCleanError(placedb({"vocab", "import", (dir / file).string(), map.string(), "--mode",
                              "seed", "--text"},
                             dir),
                     8, file);
    EXPECT_FALSE(fs::exists(map)) << file;
  }
}

TEST(CliFaults, HangUpClosesTheMapCleanly) {
  auto seq = smallSequence(30);
  auto dir = scratchDir("CliFaults_sighup");
  auto map = (dir / "m.placedb").string(), log = (dir / "run.csv").string();
  Process mapping({PLACEDB_CLI_BINARY, "map", map, (seq / "frames.txt").string(), "--log", log},
                  dir);
  for (int i = 0; i < 1000; ++i) {
    if (fs::exists(log) && lines(bytesOf(log)).size() >= 3) break;
    ::usleep(10000);
  }
  mapping.signal(SIGHUP);
  auto stopped = mapping.wait();
  EXPECT_EQ(stopped.exit_code, 0) << describe(stopped);
  storage::SqliteMapStore store(map, storage::OpenMode::kReadOnly);
  ASSERT_TRUE(store.lastSession());
  EXPECT_TRUE(store.lastSession()->clean_close);
}

TEST(CliFaults, InfoCountsTheWriteAheadLogInTheSize) {
  auto seq = smallSequence(5);
  auto dir = scratchDir("CliFaults_info_wal");
  auto map = mappedCopy(seq, dir, "m.placedb");
  // A reader keeps the log from being checkpointed into the map while this writer adds rows.
  storage::SqliteMapStore writer(map.string(), storage::OpenMode::kReadWrite);
  auto tx = writer.begin();
  writer.putState("padding", std::vector<std::uint8_t>(3 << 20, 1));
  tx.commit();
  ASSERT_TRUE(fs::exists(map.string() + "-wal"));
  auto r = placedb({"info", map.string(), "--json"}, dir);
  ASSERT_EQ(r.exit_code, 0) << describe(r);
  auto about = nlohmann::json::parse(r.out);
  EXPECT_GE(about["file_bytes"].get<std::int64_t>(), 3 << 20) << r.out;
}

}  // namespace
}  // namespace placedb::testing
