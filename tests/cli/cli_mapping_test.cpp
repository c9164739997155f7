// `placedb map | query | info | eval | demo` end to end, on the small real sequence
// (rtabmap_samples, skipped when absent) and on a synthetic sequence made here.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <chrono>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <thread>

#include "cli_scratch.h"
#include "cli_test_support.h"
#include "frame_log.h"
#include "kill_at_write.h"
#include "synthetic/synthetic_sequence.h"

namespace placedb::testing {
namespace {

namespace fs = std::filesystem;
using cli::CsvTable;
using cli::readCsv;

// 60 synthetic frames in a folder of the calling test's own: ctest runs tests in parallel
// processes, so a shared folder would be rewritten under another test's feet.
fs::path demoSequence() {
  const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
  fs::path dir =
      scratchDir(std::string(test->test_suite_name()) + "_" + test->name() + "_sequence");
  synthetic::SyntheticOptions options;
  options.frames = 60;
  synthetic::writeSequence(synthetic::SyntheticSequence(options), dir);
  return dir;
}

std::vector<std::int64_t> frameColumn(const CsvTable& log) {
  std::vector<std::int64_t> frames;
  int column = log.column("frame");
  for (std::size_t i = 0; i < log.rows.size(); ++i)
    frames.push_back(std::stoll(log.cell(i, column)));
  return frames;
}

std::vector<std::int64_t> range(std::int64_t first, std::int64_t last) {
  std::vector<std::int64_t> values;
  for (std::int64_t i = first; i <= last; ++i) values.push_back(i);
  return values;
}

nlohmann::json info(const fs::path& map, const fs::path& scratch) {
  auto r = placedb({"info", map.string(), "--json"}, scratch);
  EXPECT_EQ(r.exit_code, 0) << describe(r);
  return nlohmann::json::parse(r.out);
}

// The scored columns of two logs must agree row by row.
void expectSameScoredRows(const CsvTable& a, const CsvTable& b) {
  ASSERT_EQ(a.rows.size(), b.rows.size());
  for (const char* name : {"frame", "candidate_frames", "score", "accepted"}) {
    int ca = a.column(name), cb = b.column(name);
    ASSERT_GE(ca, 0);
    ASSERT_GE(cb, 0);
    for (std::size_t i = 0; i < a.rows.size(); ++i)
      EXPECT_EQ(a.cell(i, ca), b.cell(i, cb)) << name << " differs at row " << i;
  }
}

// A calibration as ROS's camera_calibration writes it gives the closures a relative pose.
TEST(CliRealSequence, RosCalibrationYamlGivesClosuresAPose) {
  fs::path data = dataset("rtabmap_samples");
  if (data.empty()) GTEST_SKIP() << "rtabmap_samples absent under " << datasetsDir();
  auto dir = scratchDir("CliReal_ros_calibration");
  std::ofstream(dir / "ost.yaml") << "image_width: 512\nimage_height: 384\n"
                                     "camera_name: camera\ncamera_matrix:\n  rows: 3\n"
                                     "  cols: 3\n  data: [420, 0, 256, 0, 420, 192, 0, 0, 1]\n"
                                     "distortion_model: plumb_bob\ndistortion_coefficients:\n"
                                     "  rows: 1\n  cols: 5\n  data: [0, 0, 0, 0, 0]\n";
  auto map = dir / "run.placedb";
  auto mapped = placedb({"map", map.string(), (data / "frames.txt").string(), "--calibration",
                         (dir / "ost.yaml").string(), "-q"},
                        dir);
  ASSERT_EQ(mapped.exit_code, 0) << describe(mapped);
  ASSERT_EQ(placedb({"export", map.string(), (dir / "g.g2o").string()}, dir).exit_code, 0);
  std::ifstream g2o(dir / "g.g2o");
  int appearance_only = 0, edges = 0;
  for (std::string line; std::getline(g2o, line);) {
    appearance_only += line.rfind("# placedb appearance-only", 0) == 0;
    edges += line.rfind("EDGE_SE3:QUAT", 0) == 0;
  }
  auto info = placedb({"info", map.string(), "--json"}, dir);
  ASSERT_EQ(info.exit_code, 0) << describe(info);
  const auto j = nlohmann::json::parse(info.out);
  const int closures = j.at("loop_closures").get<int>();
  ASSERT_GT(closures, 30);
  EXPECT_LT(appearance_only, closures / 2) << "most closures carry a pose";
  EXPECT_GT(edges, closures);
}

// One definition of each count: map's closure lines and summary, info and the log agree on
// frames, bad frames and accepted closures; loop-closure links are fewer where frames merged
// into one location close on one place.
TEST(CliRealSequence, CountsAgreeAcrossMapInfoAndLog) {
  fs::path data = dataset("rtabmap_samples");
  if (data.empty()) GTEST_SKIP() << "rtabmap_samples absent under " << datasetsDir();
  auto dir = scratchDir("CliReal_counts");
  auto map = dir / "run.placedb", log = dir / "run.csv";
  auto mapped =
      placedb({"map", map.string(), (data / "frames.txt").string(), "--log", log.string()}, dir);
  ASSERT_EQ(mapped.exit_code, 0) << describe(mapped);
  const CsvTable table = readCsv(log);
  std::int64_t accepted = 0, bad = 0;
  for (std::size_t i = 0; i < table.rows.size(); ++i) {
    accepted += table.cell(i, table.column("accepted")) == "1";
    bad += table.cell(i, table.column("outcome")) == "bad";
  }
  ASSERT_GT(accepted, 30);
  std::int64_t lines = 0;
  for (std::size_t at = 0;
       (at = mapped.err.find("closes a loop on frame", at)) != std::string::npos; ++at)
    ++lines;
  EXPECT_EQ(lines, accepted);
  EXPECT_NE(mapped.err.find(fmt::format("84 frames ({} bad, 0 of them unreadable)", bad)),
            std::string::npos)
      << mapped.err;
  EXPECT_NE(mapped.err.find(fmt::format("accepted loop closures {}", accepted)), std::string::npos)
      << mapped.err;
  const nlohmann::json j = info(map.string(), dir);
  EXPECT_EQ(j["frames"], 84);
  EXPECT_EQ(j["bad_frames"], bad);
  EXPECT_EQ(j["accepted_closures"], accepted);
  EXPECT_EQ(j["posed_closures"], 0) << "no intrinsics, no pose";
  EXPECT_LE(j["loop_closures"].get<std::int64_t>(), accepted);
  auto text = placedb({"info", map.string()}, dir);
  EXPECT_NE(
      text.out.find(fmt::format("frames 84 ({} bad), accepted loop closures {}", bad, accepted)),
      std::string::npos)
      << text.out;
  // The report without ground truth counts the same closures.
  auto report = placedb({"report", map.string(), log.string(), "--out", (dir / "r").string()}, dir);
  ASSERT_EQ(report.exit_code, 0) << describe(report);
  EXPECT_NE(bytesOf(dir / "r" / "index.html")
                .find(fmt::format("<h2>Accepted loop closures: {}</h2>", accepted)),
            std::string::npos);
}

TEST(CliRealSequence, MapEvalInfoQueryOnRtabmapSamples) {
  fs::path data = dataset("rtabmap_samples");
  if (data.empty()) GTEST_SKIP() << "rtabmap_samples absent under " << datasetsDir();
  auto dir = scratchDir("CliReal_rtabmap");
  auto map = dir / "run.placedb", log = dir / "run.csv";

  auto mapped =
      placedb({"map", map.string(), (data / "frames.txt").string(), "--log", log.string()}, dir);
  ASSERT_EQ(mapped.exit_code, 0) << describe(mapped);
  EXPECT_NE(mapped.err.find("frames/s"), std::string::npos) << "no progress line: " << mapped.err;
  CsvTable table = readCsv(log);
  EXPECT_EQ(frameColumn(table), range(0, 83));
  EXPECT_EQ(table.header.front(), "frame");
  // EVALUATION.md: a hypothesis the ratio test rejected scores 0 in the scored column.
  int score = table.column("score"), raw = table.column("raw_score"),
      reason = table.column("rejected_reason"), accepted = table.column("accepted");
  ASSERT_GE(raw, 0);
  for (std::size_t i = 0; i < table.rows.size(); ++i) {
    if (table.cell(i, reason) == "ratio_test") {
      EXPECT_EQ(table.cell(i, score), "0") << "row " << i;
    }
    if (table.cell(i, accepted) == "1") {
      EXPECT_EQ(table.cell(i, score), table.cell(i, raw)) << "row " << i;
    }
  }

  // Our scores equal the reference scorer's, figure for figure, for both windows.
  for (const char* window : {"0", "10"}) {
    auto ours =
        placedb({"eval", log.string(), (data / "gt_pairs.txt").string(), "--window", window}, dir);
    ASSERT_EQ(ours.exit_code, 0) << describe(ours);
    auto reference =
        run({"/usr/bin/python3", (datasetsDir() / ".." / "tools" / "score_loops.py").string(),
             log.string(), (data / "gt_pairs.txt").string(), "--window", window},
            dir);
    ASSERT_EQ(reference.exit_code, 0) << reference.err;
    EXPECT_EQ(ours.out, reference.out);
  }
  auto json = placedb({"eval", log.string(), (data / "gt_pairs.txt").string(), "--json"}, dir);
  auto json_reference =
      run({"/usr/bin/python3", (datasetsDir() / ".." / "tools" / "score_loops.py").string(),
           log.string(), (data / "gt_pairs.txt").string(), "--json"},
          dir);
  EXPECT_EQ(json.out, json_reference.out);

  // A log in the bare reference format takes the series it lacks from the map.
  {
    std::ofstream bare(dir / "bare.csv");
    bare << "frame,candidate_frames,score,accepted,time_ms\n";
    for (std::size_t i = 0; i < table.rows.size(); ++i) {
      for (int c = 0; c < 5; ++c)
        bare << (c ? "," : "") << table.rows[i][static_cast<std::size_t>(c)];
      bare << "\n";
    }
  }
  auto from_map = placedb({"eval", (dir / "bare.csv").string(), (data / "gt_pairs.txt").string(),
                           "--plots", (dir / "bare_plots").string(), "--map", map.string()},
                          dir);
  ASSERT_EQ(from_map.exit_code, 0) << describe(from_map);
  EXPECT_FALSE(cv::imread((dir / "bare_plots" / "vocabulary.png").string()).empty());
  EXPECT_FALSE(cv::imread((dir / "bare_plots" / "wm_size.png").string()).empty());
  EXPECT_FALSE(cv::imread((dir / "bare_plots" / "time_by_stage.png").string()).empty());

  auto plotted = placedb({"eval", log.string(), (data / "gt_pairs.txt").string(), "--plots",
                          (dir / "plots").string(), "--map", map.string()},
                         dir);
  ASSERT_EQ(plotted.exit_code, 0) << describe(plotted);
  for (const char* png :
       {"precision_recall.png", "score.png", "vocabulary.png", "quantisation_error.png",
        "wm_size.png", "time.png", "time_by_stage.png", "loop_matrix.png"}) {
    cv::Mat image = cv::imread((dir / "plots" / png).string());
    EXPECT_FALSE(image.empty()) << png;
  }

  nlohmann::json about = info(map, dir);
  ASSERT_EQ(about["sessions"].size(), 1u);
  EXPECT_EQ(about["sessions"][0]["frames"], 84);
  EXPECT_EQ(about["sessions"][0]["clean_close"], true);
  EXPECT_EQ(about["frames"], 84);
  EXPECT_GT(about["words"].get<std::int64_t>(), 0);
  EXPECT_GT(about["locations"].get<std::int64_t>(), 0);
  // The samples revisit their start: accepted closures are stored as links.
  EXPECT_GT(about["loop_closures"].get<std::int64_t>(), 0);
  std::int64_t bad_in_log = 0;
  {
    std::ifstream rows(log);
    for (std::string row; std::getline(rows, row);)
      bad_in_log += row.find(",bad,") != std::string::npos;
  }
  EXPECT_EQ(about["bad_frames"].get<std::int64_t>(), bad_in_log);
  EXPECT_GT(about["index_words"].get<std::int64_t>(), 0);
  EXPECT_LE(about["index_words"].get<std::int64_t>(), about["words"].get<std::int64_t>());
  auto text = placedb({"info", map.string()}, dir);
  EXPECT_EQ(text.exit_code, 0);
  EXPECT_NE(text.out.find("session 1: 84 frames"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("frames 84 (" + std::to_string(bad_in_log) + " bad), accepted loop " +
                          "closures " + about["accepted_closures"].dump()),
            std::string::npos)
      << text.out;
  EXPECT_NE(text.out.find("loop-closure links " + about["loop_closures"].dump()), std::string::npos)
      << text.out;
  EXPECT_NE(text.out.find("in the kd-index after the last frame"), std::string::npos) << text.out;

  // The graph for other tools: every location and every loop closure, in each format.
  auto occurrences = [](const fs::path& file, const std::string& needle) {
    std::ifstream in(file);
    std::int64_t n = 0;
    for (std::string line; std::getline(in, line);) n += line.find(needle) != std::string::npos;
    return n;
  };
  const std::int64_t locations = about["locations"], closures = about["loop_closures"];
  for (const char* format : {"graphml", "g2o", "csv"}) {
    auto exported = placedb({"export", map.string(),
                             (dir / (std::string("graph.") + format)).string(), "--format", format},
                            dir);
    ASSERT_EQ(exported.exit_code, 0) << describe(exported);
  }
  EXPECT_EQ(occurrences(dir / "graph.graphml", "<node id="), locations);
  EXPECT_EQ(occurrences(dir / "graph.graphml", ">loop_closure<"), closures);
  EXPECT_EQ(occurrences(dir / "graph.graphml", "<data key=\"appearance_only\">true"), closures);
  EXPECT_EQ(occurrences(dir / "graph.g2o", "VERTEX_SE3:QUAT"), locations);
  EXPECT_EQ(occurrences(dir / "graph.g2o", "# placedb appearance-only"), closures);
  EXPECT_GT(occurrences(dir / "graph.g2o", "EDGE_SE3:QUAT"), closures);  // and odometry
  EXPECT_EQ(occurrences(dir / "graph.csv" / "locations.csv", ","), locations + 1);
  EXPECT_EQ(occurrences(dir / "graph.csv" / "links.csv", ",loop_closure,"), closures);
  expectCleanError(placedb({"export", map.string(), "x", "--format", "dot"}, dir), 2);
  expectCleanError(
      placedb({"export", (dir / "absent.placedb").string(), "x", "--format", "csv"}, dir), 3);

  // A mapped image finds its own place; the map file is not changed by a query.
  auto before = fs::last_write_time(map);
  auto size_before = fs::file_size(map);
  std::vector<std::string> list;
  {
    std::ifstream frames(data / "frames.txt");
    for (std::string line; std::getline(frames, line);)
      if (!line.empty() && line[0] != '#') list.push_back((data / line).string());
  }
  ASSERT_GT(list.size(), 20u);
  auto query = placedb({"query", map.string(), list[20], "--json", "--top", "3"}, dir);
  ASSERT_EQ(query.exit_code, 0) << describe(query);
  auto answers = nlohmann::json::parse(query.out);
  ASSERT_EQ(answers.size(), 1u);
  ASSERT_FALSE(answers[0]["matches"].empty());
  EXPECT_LE(answers[0]["matches"].size(), 3u);
  bool found_itself = false;
  for (const auto& match : answers[0]["matches"])
    for (const auto& frame : match["frames"])
      if (std::llabs(frame["source_index"].get<std::int64_t>() - 20) <= 2) found_itself = true;
  EXPECT_TRUE(found_itself) << query.out;
  EXPECT_EQ(fs::file_size(map), size_before);
  EXPECT_EQ(fs::last_write_time(map), before);
  auto query_text = placedb({"query", map.string(), list[20]}, dir);
  EXPECT_NE(query_text.out.find("similarity"), std::string::npos) << query_text.out;
  // An unreadable image is reported with status 3; the readable ones are still answered.
  std::ofstream(dir / "empty.png");
  auto partly = placedb({"query", map.string(), (dir / "empty.png").string(), list[30]}, dir);
  EXPECT_EQ(partly.exit_code, 3) << describe(partly);
  EXPECT_NE(partly.err.find("placedb: error: cannot read image"), std::string::npos) << partly.err;
  EXPECT_NE(partly.out.find(list[30]), std::string::npos) << partly.out;
}

// A run stopped early says where it stands in the source, not only in its own count; eval's
// nan and None (kept byte for byte as score_loops.py prints them) are explained on stderr.
TEST(CliSyntheticSequence, ProgressTellsThePlaceInTheSourceAndEvalExplainsNan) {
  auto seq = smallSequence(12);
  auto dir = scratchDir("CliSynthetic_progress");
  const auto log = dir / "run.csv";
  auto r = placedb({"map", (dir / "m.placedb").string(), (seq / "frames.txt").string(),
                    "--stop-after", "5", "--log", log.string()},
                   dir);
  ASSERT_EQ(r.exit_code, 0) << describe(r);
  EXPECT_NE(r.err.find("5/5 frames"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("frame 4 of 12"), std::string::npos) << r.err;
  std::ofstream(dir / "no_loops.txt") << "# no revisits\n";
  auto e = placedb({"eval", log.string(), (dir / "no_loops.txt").string()}, dir);
  ASSERT_EQ(e.exit_code, 0) << describe(e);
  EXPECT_NE(e.out.find("recall_at_100_precision: nan"), std::string::npos) << e.out;
  EXPECT_NE(e.err.find("placedb: note: recall_at_100_precision is nan"), std::string::npos)
      << e.err;
}

TEST(CliSyntheticSequence, SplitRunEqualsStraightRun) {
  auto seq = demoSequence();
  auto dir = scratchDir("CliSynthetic_split");
  auto source = (seq / "frames.txt").string();
  auto straight = placedb(
      {"map", (dir / "a.placedb").string(), source, "--log", (dir / "a.csv").string()}, dir);
  ASSERT_EQ(straight.exit_code, 0) << describe(straight);

  auto b = (dir / "b.placedb").string(), b_log = (dir / "b.csv").string();
  auto first = placedb({"map", b, source, "--log", b_log, "--stop-after", "30"}, dir);
  ASSERT_EQ(first.exit_code, 0) << describe(first);
  EXPECT_EQ(frameColumn(readCsv(b_log)), range(0, 29));
  nlohmann::json halfway = info(b, dir);
  ASSERT_EQ(halfway["sessions"].size(), 1u);
  EXPECT_EQ(halfway["sessions"][0]["clean_close"], true);
  EXPECT_EQ(halfway["sessions"][0]["last_source_index"], 29);

  auto second = placedb({"map", b, source, "--log", b_log}, dir);
  ASSERT_EQ(second.exit_code, 0) << describe(second);
  EXPECT_NE(second.err.find("resuming session 1"), std::string::npos) << second.err;
  CsvTable split = readCsv(b_log);  // one header only: a second one would be a row here
  EXPECT_EQ(frameColumn(split), range(0, 59));
  expectSameScoredRows(readCsv(dir / "a.csv"), split);

  nlohmann::json done = info(b, dir);
  ASSERT_EQ(done["sessions"].size(), 1u);
  EXPECT_EQ(done["sessions"][0]["frames"], 60);

  // The source is finished: mapping it again starts session 2, with frames counted from 0.
  auto third =
      placedb({"map", b, source, "--log", (dir / "b2.csv").string(), "--stop-after", "5"}, dir);
  ASSERT_EQ(third.exit_code, 0) << describe(third);
  EXPECT_EQ(frameColumn(readCsv(dir / "b2.csv")), range(0, 4));
  EXPECT_EQ(info(b, dir)["sessions"].size(), 2u);
}

// The map loses its last commits (a power cut with synchronous=NORMAL loses the -wal): the log
// still holds their rows. The resume cuts the log back to the map's last durable frame, so every
// frame is in it once and scores as in a straight run.
TEST(CliSyntheticSequence, ResumeAfterLostCommitsCutsTheLogBack) {
  auto seq = demoSequence();
  auto dir = scratchDir("CliSynthetic_lost_commits");
  auto source = (seq / "frames.txt").string();
  auto straight = placedb(
      {"map", (dir / "a.placedb").string(), source, "--log", (dir / "a.csv").string()}, dir);
  ASSERT_EQ(straight.exit_code, 0) << describe(straight);

  auto b = dir / "b.placedb";
  const std::string b_log = (dir / "b.csv").string();
  ASSERT_EQ(placedb({"map", b.string(), source, "--log", b_log, "--stop-after", "20", "-q"}, dir)
                .exit_code,
            0);
  fs::copy_file(b, dir / "durable.placedb");  // the map as the last durable commit left it
  ASSERT_EQ(placedb({"map", b.string(), source, "--log", b_log, "--stop-after", "12", "-q"}, dir)
                .exit_code,
            0);
  ASSERT_EQ(frameColumn(readCsv(b_log)), range(0, 31));
  fs::copy_file(dir / "durable.placedb", b, fs::copy_options::overwrite_existing);

  auto resumed = placedb({"map", b.string(), source, "--log", b_log}, dir);
  ASSERT_EQ(resumed.exit_code, 0) << describe(resumed);
  EXPECT_NE(resumed.err.find("frames 20-31"), std::string::npos) << resumed.err;
  const CsvTable log = readCsv(b_log);
  EXPECT_EQ(frameColumn(log), range(0, 59));
  expectSameScoredRows(readCsv(dir / "a.csv"), log);
}

// Killed between a frame's commit and its log row (SIGKILL at the entry of the row's write): the
// map holds the frame, the log lacks it. The resume writes the row back from the map, so the
// log holds every frame once, scored as in a straight run.
TEST(CliSyntheticSequence, KillBetweenCommitAndLogRowLosesNoRow) {
  if (!kCanKillAtWrite) GTEST_SKIP() << "the system-call trap reads x86-64 registers";
  auto seq = demoSequence();
  auto dir = scratchDir("CliSynthetic_kill_before_row");
  auto source = (seq / "frames.txt").string();
  auto straight = placedb(
      {"map", (dir / "a.placedb").string(), source, "--log", (dir / "a.csv").string()}, dir);
  ASSERT_EQ(straight.exit_code, 0) << describe(straight);

  const auto b = (dir / "b.placedb").string();
  const fs::path b_log = dir / "b.csv";
  bool killed = false;
  // Write 1 is the header; write 27 would be the row of frame 25.
  runKilledAtWrite({PLACEDB_CLI_BINARY, "map", b, source, "--log", b_log.string(), "-q"}, b_log, 27,
                   &killed);
  ASSERT_TRUE(killed) << "the run ended before its 27th write to the log";
  EXPECT_EQ(frameColumn(readCsv(b_log)), range(0, 24));
  EXPECT_EQ(info(b, dir)["sessions"][0]["last_source_index"], 25);

  auto resumed = placedb({"map", b, source, "--log", b_log.string()}, dir);
  ASSERT_EQ(resumed.exit_code, 0) << describe(resumed);
  EXPECT_NE(resumed.err.find("wrote back from the map the rows of frame 25,"), std::string::npos)
      << resumed.err;
  const CsvTable log = readCsv(b_log);
  EXPECT_EQ(frameColumn(log), range(0, 59));
  expectSameScoredRows(readCsv(dir / "a.csv"), log);
  // The summary counts this run's frames, not the one written back.
  EXPECT_NE(resumed.err.find(": 34 frames"), std::string::npos) << resumed.err;
}

TEST(CliSyntheticSequence, LogToStandardOutput) {
  auto seq = smallSequence(6);
  auto dir = scratchDir("CliSynthetic_log_stdout");
  auto r = placedb(
      {"map", (dir / "m.placedb").string(), (seq / "frames.txt").string(), "--log", "-"}, dir);
  ASSERT_EQ(r.exit_code, 0) << describe(r);
  EXPECT_FALSE(fs::exists(fs::current_path() / "-")) << "no file named -";
  EXPECT_FALSE(fs::exists(dir / "-"));
  std::ofstream(dir / "stdout.csv") << r.out;
  const CsvTable log = readCsv(dir / "stdout.csv");
  EXPECT_EQ(log.header, cli::FrameLogWriter::columns());
  EXPECT_EQ(frameColumn(log), range(0, 5));
}

TEST(CliSyntheticSequence, VocabularyExport) {
  auto seq = demoSequence();
  auto dir = scratchDir("CliSynthetic_vocab");
  auto map = (dir / "m.placedb").string();
  auto mapped =
      placedb({"map", map, (seq / "frames.txt").string(), "--stop-after", "15", "-q"}, dir);
  ASSERT_EQ(mapped.exit_code, 0) << describe(mapped);
  std::int64_t words = info(fs::path(map), dir)["words"];
  ASSERT_GT(words, 0);
  auto binary = placedb({"vocab", "export", map, (dir / "words.pvoc").string()}, dir);
  ASSERT_EQ(binary.exit_code, 0) << describe(binary);
  EXPECT_GT(fs::file_size(dir / "words.pvoc"), static_cast<std::uintmax_t>(words) * 64 * 4);
  auto text =
      placedb({"vocab", "export", map, (dir / "words.txt").string(), "--format", "rtabmap"}, dir);
  ASSERT_EQ(text.exit_code, 0) << describe(text);
  std::ifstream in(dir / "words.txt");
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "WordID Descriptors...64");  // RTAB-Map reads the dimension from it
  std::int64_t lines = 0;
  for (std::string line; std::getline(in, line);) lines += line.empty() ? 0 : 1;
  EXPECT_EQ(lines, words);

  // Export -> import -> export gives the same file, byte for byte, in both forms.
  auto fileOf = [](const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(f), {});
  };
  const auto imported = (dir / "imported.placedb").string();
  auto import =
      placedb({"vocab", "import", (dir / "words.pvoc").string(), imported, "--mode", "fixed"}, dir);
  ASSERT_EQ(import.exit_code, 0) << describe(import);
  EXPECT_EQ(info(fs::path(imported), dir)["words"], words);
  ASSERT_EQ(placedb({"vocab", "export", imported, (dir / "again.pvoc").string()}, dir).exit_code,
            0);
  EXPECT_EQ(fileOf(dir / "again.pvoc"), fileOf(dir / "words.pvoc"));
  const auto from_text = (dir / "from_text.placedb").string();
  ASSERT_EQ(placedb({"vocab", "import", (dir / "words.txt").string(), from_text, "--mode", "seed",
                     "--format", "rtabmap"},
                    dir)
                .exit_code,
            0);
  ASSERT_EQ(placedb({"vocab", "export", from_text, (dir / "again.txt").string(), "--text"}, dir)
                .exit_code,
            0);
  EXPECT_EQ(fileOf(dir / "again.txt"), fileOf(dir / "words.txt"));

  // The fixed map maps the rest of the sequence without a new word.
  auto rest = placedb({"map", imported, (seq / "frames.txt").string(), "-q"}, dir);
  ASSERT_EQ(rest.exit_code, 0) << describe(rest);
  EXPECT_EQ(info(fs::path(imported), dir)["words"], words);

  // Refusals: a damaged file (8, and no map left behind), a map that already has frames (2).
  std::ofstream(dir / "junk.pvoc") << "definitely not a vocabulary file";
  expectCleanError(placedb({"vocab", "import", (dir / "junk.pvoc").string(),
                            (dir / "new.placedb").string(), "--mode", "seed"},
                           dir),
                   8);
  EXPECT_FALSE(fs::exists(dir / "new.placedb"));
  expectCleanError(
      placedb({"vocab", "import", (dir / "words.pvoc").string(), map, "--mode", "seed"}, dir), 2,
      "new map only");
}

TEST(CliSyntheticSequence, SettingsAreStoredAndKeptOnResume) {
  auto seq = demoSequence();
  auto dir = scratchDir("CliSynthetic_settings");
  auto map = (dir / "m.placedb").string();
  std::ofstream(dir / "run.conf") << "t_loop = 0.3\nstm_size = 8\n";
  auto r = placedb({"map", map, (seq / "images").string(), "--stop-after", "10", "--config",
                    (dir / "run.conf").string(), "--set", "t_loop=0.25", "--quiet"},
                   dir);
  ASSERT_EQ(r.exit_code, 0) << describe(r);
  EXPECT_EQ(lines(r.err).size(), 1u) << "--quiet prints the summary only: " << r.err;
  auto settings = info(fs::path(map), dir)["sessions"][0]["settings"];
  EXPECT_EQ(settings["t_loop"], "0.25");
  EXPECT_EQ(settings["stm_size"], "8");
  // Resuming with other settings warns and keeps the stored ones.
  auto resumed = placedb(
      {"map", map, (seq / "images").string(), "--stop-after", "5", "--set", "t_loop=0.5"}, dir);
  ASSERT_EQ(resumed.exit_code, 0) << describe(resumed);
  EXPECT_NE(resumed.err.find("placedb: warning: resuming session 1"), std::string::npos)
      << resumed.err;
  auto after = info(fs::path(map), dir);
  ASSERT_EQ(after["sessions"].size(), 1u);
  EXPECT_EQ(after["sessions"][0]["settings"]["t_loop"], "0.25");
  EXPECT_EQ(after["sessions"][0]["frames"], 15);
}

TEST(CliSyntheticSequence, UnreadableImagesGetARowAndAWarning) {
  auto seq = demoSequence();
  auto dir = scratchDir("CliSynthetic_unreadable");
  fs::create_directories(dir / "frames");
  std::vector<std::string> images;
  for (const auto& entry : fs::directory_iterator(seq / "images")) images.push_back(entry.path());
  std::sort(images.begin(), images.end());
  for (int i = 0; i < 8; ++i)
    fs::copy_file(images[static_cast<std::size_t>(i)],
                  dir / "frames" / (std::to_string(i) + ".png"));
  std::ofstream(dir / "frames" / "8.png");  // zero bytes
  std::ofstream(dir / "frames" / "9.jpg") << "random bytes, not a JPEG";
  std::ofstream(dir / "frames" / "readme.txt") << "not an image";
  auto log = dir / "run.csv";
  auto r = placedb(
      {"map", (dir / "m.placedb").string(), (dir / "frames").string(), "--log", log.string()}, dir);
  ASSERT_EQ(r.exit_code, 0) << describe(r);
  EXPECT_NE(r.err.find("placedb: warning: frame 8"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("placedb: warning: frame 9"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("readme.txt"), std::string::npos) << r.err;
  CsvTable table = readCsv(log);
  EXPECT_EQ(frameColumn(table), range(0, 9));
  int outcome = table.column("outcome");
  EXPECT_EQ(table.cell(8, outcome), "bad");
  EXPECT_EQ(table.cell(9, outcome), "bad");
}

TEST(CliSyntheticSequence, InterruptClosesCleanlyAndResumes) {
  auto seq = demoSequence();
  auto dir = scratchDir("CliSynthetic_interrupt");
  auto map = (dir / "m.placedb").string(), log = (dir / "run.csv").string();
  std::vector<std::string> argv = {
      PLACEDB_CLI_BINARY, "map", map, (seq / "frames.txt").string(), "--log", log};
  Process mapping(argv, dir);
  // Wait for a few rows, then Ctrl-C.
  for (int i = 0; i < 400; ++i) {
    if (fs::exists(log) && readCsv(log).rows.size() >= 3) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  mapping.signal(SIGINT);
  auto stopped = mapping.wait();
  ASSERT_EQ(stopped.exit_code, 0) << describe(stopped);
  auto about = info(fs::path(map), dir);
  EXPECT_EQ(about["sessions"][0]["clean_close"], true);
  auto rest = placedb({"map", map, (seq / "frames.txt").string(), "--log", log}, dir);
  ASSERT_EQ(rest.exit_code, 0) << describe(rest);
  EXPECT_EQ(frameColumn(readCsv(log)), range(0, 59));
  EXPECT_EQ(info(fs::path(map), dir)["sessions"].size(), 1u);
}

TEST(CliSyntheticSequence, VideoSourceCountsFramesFromTheStart) {
  auto seq = demoSequence();
  auto dir = scratchDir("CliSynthetic_video");
  auto video = (dir / "tour.avi").string();
  {
    cv::VideoWriter writer(video, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10,
                           cv::Size(320, 240), false);
    if (!writer.isOpened()) GTEST_SKIP() << "OpenCV cannot write MJPG video here";
    for (int i = 0; i < 20; ++i) {
      char name[32];
      std::snprintf(name, sizeof name, "%06d.png", i);
      writer.write(cv::imread((seq / "images" / name).string(), cv::IMREAD_GRAYSCALE));
    }
  }
  auto map = (dir / "m.placedb").string(), log = (dir / "run.csv").string();
  auto first = placedb({"map", map, video, "--log", log, "--stop-after", "8", "-q"}, dir);
  ASSERT_EQ(first.exit_code, 0) << describe(first);
  auto rest = placedb({"map", map, video, "--log", log, "-q"}, dir);
  ASSERT_EQ(rest.exit_code, 0) << describe(rest);
  EXPECT_EQ(frameColumn(readCsv(log)), range(0, 19));
  auto about = info(fs::path(map), dir);
  ASSERT_EQ(about["sessions"].size(), 1u);
  EXPECT_EQ(about["sessions"][0]["frames"], 20);
}

TEST(CliDemo, MapsScoresAndPlotsWithoutOutsideData) {
  auto dir = scratchDir("CliDemo");
  auto r = placedb({"demo", "--out", (dir / "out").string(), "--frames", "60"}, dir);
  ASSERT_EQ(r.exit_code, 0) << describe(r);
  EXPECT_NE(r.out.find("recall_at_100_precision"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(dir / "out" / "demo.placedb"));
  EXPECT_EQ(frameColumn(readCsv(dir / "out" / "run.csv")), range(0, 59));
  for (const char* png : {"score.png", "vocabulary.png", "wm_size.png", "time.png"})
    EXPECT_FALSE(cv::imread((dir / "out" / "plots" / png).string()).empty()) << png;
  // Its hints run as printed, placedb on PATH or not (the test's PATH does not hold it).
  const std::string hint = "what the map holds:";
  const auto at = r.out.find(hint);
  ASSERT_NE(at, std::string::npos) << r.out;
  const std::string command =
      r.out.substr(at + hint.size(), r.out.find('\n', at) - at - hint.size());
  const auto hinted = run({"/bin/bash", "-c", command}, dir);
  EXPECT_EQ(hinted.exit_code, 0) << command << "\n" << describe(hinted);
  // Running it again starts afresh rather than resuming the finished demo map.
  auto again = placedb({"demo", "--out", (dir / "out").string(), "--frames", "60"}, dir);
  ASSERT_EQ(again.exit_code, 0) << describe(again);
  EXPECT_EQ(frameColumn(readCsv(dir / "out" / "run.csv")), range(0, 59));
}

// The default tour, scored against its own ground truth: every closure the engine accepts is
// onto ground the camera has seen. Its last street leads back to the start, and the closures
// from frame 179 on, made while the camera approaches frame 0's place, are right (see
// GroundTruth.DemoTourApproachingItsStartRevisitsIt).
TEST(CliDemo, DefaultTourAcceptsNoWrongClosure) {
  auto dir = scratchDir("CliDemo_default");
  auto r = placedb({"demo", "--out", (dir / "out").string()}, dir);
  ASSERT_EQ(r.exit_code, 0) << describe(r);
  EXPECT_NE(r.out.find("\naccepted_false: 0\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\naccepted_precision: 100.0\n"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace placedb::testing
