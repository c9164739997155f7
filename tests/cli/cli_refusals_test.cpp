// Bad input given to `placedb`: a folder where a file belongs, an unusable query image, the map as
// an export's output, settings a component refuses, a log that cannot or must not be written, an
// empty list. Each gives its documented exit status, names the file, and leaves every file as it
// was; a resumed session takes its stored settings.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cli_scratch.h"
#include "placedb/storage/sqlite_map_store.h"

namespace placedb::testing {
namespace {

namespace fs = std::filesystem;

std::string listOf(const fs::path& seq, int first, int count) {
  std::string text;
  for (int i = first; i < first + count; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "images/%06d.png", i);
    text += (seq / name).string() + "\n";
  }
  return text;
}

TEST(CliRefusals, FolderInAListIsABadFrameAndAFolderConfigIsIo) {
  auto seq = smallSequence(6);
  auto dir = scratchDir("CliRefusals_folder");
  fs::create_directories(dir / "a_folder.png");
  std::ofstream(dir / "list.txt") << listOf(seq, 0, 3) << (dir / "a_folder.png").string() << "\n"
                                  << listOf(seq, 3, 3);
  auto map = (dir / "m.placedb").string();
  auto r = placedb({"map", map, (dir / "list.txt").string(), "-q"}, dir);
  ASSERT_EQ(r.exit_code, 0) << describe(r);
  EXPECT_NE(r.err.find("placedb: warning: frame 3 (" + (dir / "a_folder.png").string()),
            std::string::npos)
      << r.err;

  auto query = placedb(
      {"query", map, (dir / "a_folder.png").string(), (seq / "images" / "000001.png").string()},
      dir);
  EXPECT_EQ(query.exit_code, 3) << describe(query);
  EXPECT_NE(query.err.find("a_folder.png"), std::string::npos) << query.err;
  EXPECT_NE(query.out.find("000001.png"), std::string::npos) << query.out;

  const std::string before = bytesOf(map);
  expectCleanError(placedb({"map", map, (dir / "list.txt").string(), "--new-session", "--config",
                            (dir / "a_folder.png").string()},
                           dir),
                   3, "a_folder.png");
  EXPECT_TRUE(bytesOf(map) == before);
}

TEST(CliRefusals, QueryAnswersEveryImageAfterAnUnusableOne) {
  auto seq = smallSequence(6);
  auto dir = scratchDir("CliRefusals_query");
  auto map = (dir / "m.placedb").string();
  ASSERT_EQ(placedb({"map", map, (seq / "frames.txt").string(), "-q"}, dir).exit_code, 0);
  cv::imwrite((dir / "one.png").string(), cv::Mat(1, 1, CV_8UC1, cv::Scalar(7)));
  const auto good = (seq / "images" / "000002.png").string();
  auto r = placedb({"query", map, (dir / "one.png").string(), good}, dir);
  EXPECT_EQ(r.exit_code, 3) << describe(r);
  EXPECT_EQ(r.err.rfind("placedb: error: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("one.png"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find(good + ":"), std::string::npos) << describe(r);
}

// A folder or a list file is as good to query as to map: each of its images is answered.
TEST(CliRefusals, QueryTakesAFolderOrAListFile) {
  auto seq = smallSequence(4);
  auto dir = scratchDir("CliRefusals_query_folder");
  auto map = (dir / "m.placedb").string();
  ASSERT_EQ(placedb({"map", map, (seq / "frames.txt").string(), "-q"}, dir).exit_code, 0);
  for (const fs::path& source : {seq / "images", seq / "frames.txt"}) {
    auto r = placedb({"query", map, source.string(), "--json"}, dir);
    ASSERT_EQ(r.exit_code, 0) << describe(r);
    const auto answers = nlohmann::json::parse(r.out);
    ASSERT_EQ(answers.size(), 4u) << source;
    EXPECT_NE(answers[3]["image"].get<std::string>().find("000003.png"), std::string::npos);
  }
  fs::create_directories(dir / "empty");
  expectCleanError(placedb({"query", map, (dir / "empty").string()}, dir), 3, "empty");
}

TEST(CliRefusals, VocabExportRefusesTheMapUnderAnyNameAndLeavesNoPartialFile) {
  auto seq = smallSequence(8);
  auto dir = scratchDir("CliRefusals_export");
  auto map = (dir / "m.placedb").string();
  ASSERT_EQ(placedb({"map", map, (seq / "frames.txt").string(), "-q"}, dir).exit_code, 0);
  fs::create_directories(dir / "sub");
  fs::create_symlink(map, dir / "link.placedb");
  const std::string before = bytesOf(map);
  for (const auto& output : std::vector<std::string>{
           map, (dir / "sub" / ".." / "m.placedb").string(), (dir / "link.placedb").string()}) {
    for (bool text : {false, true}) {
      std::vector<std::string> args = {"vocab", "export", map, output};
      if (text) args.push_back("--text");
      expectCleanError(placedb(args, dir), 2, "is the map");
      EXPECT_TRUE(bytesOf(map) == before) << output;
    }
  }
  // A good export leaves exactly its file.
  ASSERT_EQ(placedb({"vocab", "export", map, (dir / "out.pvoc").string()}, dir).exit_code, 0);
  for (const auto& entry : fs::directory_iterator(dir))
    EXPECT_EQ(entry.path().filename().string().find(".partial"), std::string::npos) << entry.path();
}

TEST(CliRefusals, GraphExportRefusesTheMapUnderAnyName) {
  auto seq = smallSequence(8);
  auto dir = scratchDir("CliRefusals_graph_export");
  auto map = (dir / "m.placedb").string();
  ASSERT_EQ(placedb({"map", map, (seq / "frames.txt").string(), "-q"}, dir).exit_code, 0);
  fs::create_directories(dir / "sub");
  fs::create_symlink(map, dir / "link.placedb");
  const std::string before = bytesOf(map);
  for (const auto& output : std::vector<std::string>{map, (dir / "." / "m.placedb").string(),
                                                     (dir / "sub" / ".." / "m.placedb").string(),
                                                     (dir / "link.placedb").string()}) {
    for (const std::string format : {"g2o", "graphml"}) {
      expectCleanError(placedb({"export", map, output, "--format", format}, dir), 2, "is the map");
      EXPECT_TRUE(bytesOf(map) == before) << output << " as " << format;
    }
  }
  ASSERT_EQ(placedb({"export", map, (dir / "g.g2o").string(), "--format", "g2o"}, dir).exit_code,
            0);
}

TEST(CliRefusals, ExportTakesItsFormatFromTheExtensionOrAsks) {
  auto seq = smallSequence(8);
  auto dir = scratchDir("CliRefusals_export_format");
  auto map = (dir / "m.placedb").string();
  ASSERT_EQ(placedb({"map", map, (seq / "frames.txt").string(), "-q"}, dir).exit_code, 0);
  auto g2o = placedb({"export", map, (dir / "g.g2o").string()}, dir);
  ASSERT_EQ(g2o.exit_code, 0) << describe(g2o);
  EXPECT_NE(bytesOf((dir / "g.g2o").string()).find("VERTEX_SE3:QUAT"), std::string::npos);
  auto graphml = placedb({"export", map, (dir / "g.GraphML").string()}, dir);
  ASSERT_EQ(graphml.exit_code, 0) << describe(graphml);
  EXPECT_NE(bytesOf((dir / "g.GraphML").string()).find("<graphml"), std::string::npos);
  expectCleanError(placedb({"export", map, (dir / "g.txt").string()}, dir), 2, "--format");
  EXPECT_FALSE(fs::exists(dir / "g.txt"));
}

TEST(CliRefusals, ResumeTakesTheSessionsStoredExtractor) {
  auto seq = smallSequence(10);
  auto dir = scratchDir("CliRefusals_resume_extractor");
  auto map = (dir / "y.placedb").string();
  auto source = (seq / "frames.txt").string();
  auto first =
      placedb({"map", map, source, "--stop-after", "4", "--set", "extractor=kaze", "-q"}, dir);
  ASSERT_EQ(first.exit_code, 0) << describe(first);
  auto rest = placedb({"map", map, source, "-q"}, dir);
  ASSERT_EQ(rest.exit_code, 0) << describe(rest);
  storage::SqliteMapStore store(map, storage::OpenMode::kReadOnly);
  ASSERT_EQ(store.sessions().size(), 1u);
  EXPECT_EQ(store.frameCount(), 10);
  EXPECT_EQ(store.settings(1).at("extractor"), "kaze");
}

TEST(CliRefusals, RefusedRunsCreateAndChangeNothing) {
  auto seq = smallSequence(5);
  auto dir = scratchDir("CliRefusals_nothing");
  auto source = (seq / "frames.txt").string();
  auto fresh = (dir / "fresh.placedb").string();
  // Settings the catalogue accepts but a component refuses, or the catalogue itself refuses;
  // camera intrinsics are all four or none.
  for (const std::string setting : {"hessian_threshold=1e308", "wm_recent_ratio=1", "fx=190"}) {
    expectCleanError(placedb({"map", fresh, source, "--set", setting}, dir), 2,
                     setting.substr(0, setting.find('=')));
    EXPECT_FALSE(fs::exists(fresh)) << setting;
    EXPECT_FALSE(fs::exists(fresh + "-lock")) << setting;
  }
  // A calibration file that is not one, or missing: named, and nothing made.
  std::ofstream(dir / "camera.txt") << "190 190 120\n";
  expectCleanError(
      placedb({"map", fresh, source, "--calibration", (dir / "camera.txt").string()}, dir), 2,
      "camera.txt");
  expectCleanError(
      placedb({"map", fresh, source, "--calibration", (dir / "absent.yml").string()}, dir), 3,
      "absent.yml");
  EXPECT_FALSE(fs::exists(fresh));

  auto map = (dir / "m.placedb").string();
  ASSERT_EQ(placedb({"map", map, source, "-q"}, dir).exit_code, 0);
  const std::string before = bytesOf(map);
  expectCleanError(placedb({"map", map, source, "--log", (dir / "nodir" / "x.csv").string()}, dir),
                   3, "nodir");
  EXPECT_FALSE(fs::exists(dir / "nodir"));
  std::ofstream(dir / "empty.txt");
  std::ofstream(dir / "comments.txt") << "# nothing here\n\n   \n# still nothing\n";
  for (const char* list : {"empty.txt", "comments.txt"})
    expectCleanError(placedb({"map", map, (dir / list).string()}, dir), 3, list);
  EXPECT_TRUE(bytesOf(map) == before);
}

// Values that parse but mean nothing, and bytes that would cut the error line that quotes them.
TEST(CliRefusals, NonsenseIntrinsicsAndNulBytesAreNamedRefusals) {
  auto seq = smallSequence(4);
  auto dir = scratchDir("CliRefusals_nonsense");
  auto source = (seq / "frames.txt").string();
  auto fresh = (dir / "fresh.placedb").string();
  expectCleanError(placedb({"map", fresh, source, "--set", "fx=1e-300", "--set", "fy=190", "--set",
                            "cx=120", "--set", "cy=90"},
                           dir),
                   2, "at least 1");
  std::ofstream(dir / "camera.json")
      << "{\"camera_matrix\": {\"type_id\": \"opencv-matrix\", \"rows\": 3, \"cols\": 3, "
         "\"dt\": \"d\", \"data\": [1e400, 0, 120, 0, 190, 90, 0, 0, 1]}}\n";
  expectCleanError(
      placedb({"map", fresh, source, "--calibration", (dir / "camera.json").string()}, dir), 2,
      "camera.json");
  {
    std::ofstream conf(dir / "nul.conf", std::ios::binary);
    conf << "t_loop = 0.1\nwm_max = 3";
    conf.put('\0');
    conf << "00\n";
  }
  const auto r = placedb({"map", fresh, source, "--config", (dir / "nul.conf").string()}, dir);
  expectCleanError(r, 2, "nul.conf line 2: holds a NUL byte");
  EXPECT_FALSE(fs::exists(fresh));
}

// A full device as an export's output: the disk-full code, and the device is left a device.
TEST(CliRefusals, ExportOntoAFullDeviceIsDiskFull) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  auto seq = smallSequence(4);
  auto dir = scratchDir("CliRefusals_dev_full");
  auto map = (dir / "m.placedb").string();
  ASSERT_EQ(placedb({"map", map, (seq / "frames.txt").string(), "-q"}, dir).exit_code, 0);
  expectCleanError(placedb({"export", map, "/dev/full", "--format", "g2o"}, dir), 7, "/dev/full");
  EXPECT_TRUE(fs::is_character_file("/dev/full"));
}

TEST(CliRefusals, LogOfAnotherRunOrFormatIsRefused) {
  auto seq = smallSequence(6);
  auto dir = scratchDir("CliRefusals_log");
  auto source = (seq / "frames.txt").string();
  auto log = (dir / "run.csv").string();
  auto map = (dir / "m.placedb").string();
  ASSERT_EQ(placedb({"map", map, source, "--log", log, "--stop-after", "3", "-q"}, dir).exit_code,
            0);
  // Resuming the same session appends to its log.
  ASSERT_EQ(placedb({"map", map, source, "--log", log, "-q"}, dir).exit_code, 0);
  const std::string done = bytesOf(log);
  EXPECT_EQ(lines(done).size(), 7u);

  // A new session (another map, or this one again) does not.
  auto other = (dir / "other.placedb").string();
  expectCleanError(placedb({"map", other, source, "--log", log}, dir), 2, log);
  EXPECT_FALSE(fs::exists(other));
  const std::string map_before = bytesOf(map);
  expectCleanError(placedb({"map", map, source, "--log", log}, dir), 2, log);
  EXPECT_TRUE(bytesOf(map) == map_before);
  EXPECT_TRUE(bytesOf(log) == done);

  std::ofstream(dir / "foreign.csv") << "frame,score\n0,0.5\n";
  expectCleanError(placedb({"map", other, source, "--log", (dir / "foreign.csv").string()}, dir), 2,
                   "foreign.csv");
  EXPECT_FALSE(fs::exists(other));
}

TEST(CliRefusals, ByteOrderMarkStartsAListOrAConfigHarmlessly) {
  auto seq = smallSequence(4);
  auto dir = scratchDir("CliRefusals_bom");
  std::ofstream(dir / "list.txt") << "\xEF\xBB\xBF" << listOf(seq, 0, 4);
  std::ofstream(dir / "run.conf") << "\xEF\xBB\xBFt_loop = 0.2\n";
  auto map = (dir / "m.placedb").string();
  auto r = placedb(
      {"map", map, (dir / "list.txt").string(), "--config", (dir / "run.conf").string(), "-q"},
      dir);
  ASSERT_EQ(r.exit_code, 0) << describe(r);
  EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
  storage::SqliteMapStore store(map, storage::OpenMode::kReadOnly);
  EXPECT_EQ(store.settings(1).at("t_loop"), "0.2");
  EXPECT_EQ(store.frameCount(), 4);
}

TEST(CliRefusals, ListEditedBetweenStopAndResumeIsNotResumedSilently) {
  auto seq = smallSequence(8);
  auto dir = scratchDir("CliRefusals_edited");
  auto list = dir / "list.txt";
  std::ofstream(list) << listOf(seq, 0, 8);
  auto map = (dir / "m.placedb").string();
  ASSERT_EQ(placedb({"map", map, list.string(), "--stop-after", "4", "-q"}, dir).exit_code, 0);
  // Frames 2 and 3 dropped: index 4 would now be another image.
  std::ofstream(list, std::ios::trunc) << listOf(seq, 0, 2) << listOf(seq, 4, 4);
  const std::string before = bytesOf(map);
  expectCleanError(placedb({"map", map, list.string()}, dir), 2, "--new-session");
  EXPECT_TRUE(bytesOf(map) == before);
  auto fresh = placedb({"map", map, list.string(), "--new-session", "-q"}, dir);
  ASSERT_EQ(fresh.exit_code, 0) << describe(fresh);
  storage::SqliteMapStore store(map, storage::OpenMode::kReadOnly);
  EXPECT_EQ(store.sessions().size(), 2u);
  EXPECT_EQ(store.frameCount(), 10);
}

TEST(CliRefusals, BrokenVideoIsOneErrorLine) {
  auto dir = scratchDir("CliRefusals_video");
  std::ofstream video(dir / "broken.mp4", std::ios::binary);
  video << std::string(
               "\0\0\0\x18"
               "ftypmp42",
               12)
        << std::string(4000, '\x33');
  video.close();
  auto r = placedb({"map", (dir / "m.placedb").string(), (dir / "broken.mp4").string(), "-q"}, dir);
  expectCleanError(r, 3, "broken.mp4");
  EXPECT_EQ(lines(r.err).size(), 1u) << r.err;
  EXPECT_FALSE(fs::exists(dir / "m.placedb"));
}

TEST(CliRefusals, StopAfterZeroIsAShortUsageError) {
  auto dir = scratchDir("CliRefusals_stop_after");
  auto r = placedb({"map", (dir / "m.placedb").string(), dir.string(), "--stop-after", "0"}, dir);
  EXPECT_EQ(r.exit_code, 2) << describe(r);
  EXPECT_LT(r.err.size(), 200u) << r.err;
  EXPECT_FALSE(fs::exists(dir / "m.placedb"));
}

// PLACEDB_SIMD (engine/src/features/cpu_support.h) is checked before anything is written: a
// value it does not know leaves no map and no demo folder behind.
TEST(CliRefusals, AnUnknownSimdLevelIsAUsageErrorThatWritesNothing) {
  auto seq = smallSequence(3);
  auto dir = scratchDir("CliRefusals_simd");
  const char* before = std::getenv("PLACEDB_SIMD");
  const std::string kept = before ? before : "";
  ::setenv("PLACEDB_SIMD", "sse4", 1);
  auto map = placedb({"map", (dir / "m.placedb").string(), (seq / "frames.txt").string()}, dir);
  auto demo = placedb({"demo", "--out", (dir / "demo").string()}, dir);
  if (before)
    ::setenv("PLACEDB_SIMD", kept.c_str(), 1);
  else
    ::unsetenv("PLACEDB_SIMD");
  expectCleanError(map, 2, "PLACEDB_SIMD is \"sse4\"");
  expectCleanError(demo, 2, "PLACEDB_SIMD");
  EXPECT_FALSE(fs::exists(dir / "m.placedb"));
  EXPECT_FALSE(fs::exists(dir / "demo"));
}

}  // namespace
}  // namespace placedb::testing
