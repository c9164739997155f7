// `placedb eval` must print exactly what the reference scorer score_loops.py prints.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "frame_log.h"
#include "placedb/error.h"
#include "report/eval.h"
#include "report/loop_matrix.h"
#include "report/run_series.h"
#include "subprocess.h"
#include "test_paths.h"

namespace placedb::cli {
namespace {

namespace fs = std::filesystem;
using placedb::testing::datasetsDir;
using placedb::testing::scratchDir;

fs::path referenceScorer() { return datasetsDir() / ".." / "tools" / "score_loops.py"; }

struct Case {
  std::string name, log, gt;
  int window = 0;
};

// Runs both scorers on the same files; every printed figure must agree byte for byte.
void expectSameAsReference(const Case& c) {
  auto dir = scratchDir("Eval_" + c.name);
  std::ofstream(dir / "log.csv") << c.log;
  std::ofstream(dir / "gt.txt") << c.gt;
  for (bool json : {false, true}) {
    std::vector<std::string> argv = {"/usr/bin/python3",
                                     referenceScorer().string(),
                                     (dir / "log.csv").string(),
                                     (dir / "gt.txt").string(),
                                     "--window",
                                     std::to_string(c.window)};
    if (json) argv.push_back("--json");
    auto reference = placedb::testing::run(argv, dir);
    ASSERT_EQ(reference.exit_code, 0) << c.name << ": " << reference.err;
    Evaluation eval = evaluate(readCsv(dir / "log.csv"), loadGroundTruth(dir / "gt.txt"), c.window);
    std::string ours = json ? figuresJson(eval.figures) : figuresText(eval.figures);
    EXPECT_EQ(ours, reference.out) << c.name << (json ? " (json)" : " (text)");
  }
}

class EvalAgainstReference : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(referenceScorer()))
      GTEST_SKIP() << "reference scorer absent: " << referenceScorer();
  }
};

const char* kHeader = "frame,candidate_frames,score,accepted,time_ms\n";

TEST_F(EvalAgainstReference, WrongHypothesesSetTheBar) {
  expectSameAsReference(
      {"bar",
       std::string(kHeader) +
           "0,,0,0,10.5\n1,,0,0,11\n2,0,0.2,0,9.25\n3,1,0.9,1,12\n4,0 1,0.5,1,8\n5,2,0.6,0,30\n"
           "6,3,0.45,1,7.125\n7,5,0.9,0,13\n",
       "# q r\n3 1\n4 0\n5 4\n6 3\n7 5\n7 6\n"});
}

TEST_F(EvalAgainstReference, NoWrongHypothesis) {
  expectSameAsReference({"no_wrong",
                         std::string(kHeader) + "0,,0,0,1\n1,0,0.3,1,2\n2,1,0.1,0,3\n3,,,0,4\n",
                         "1 0\n2 1\n3 0\n"});
}

TEST_F(EvalAgainstReference, EmptyCandidatesAndSemicolons) {
  expectSameAsReference({"semicolons",
                         std::string(kHeader) +
                             "0,,0,0,5\n1,,0.7,1,5\n2,0;1,0.4,1,6\n3,\"0 ; 2\",0.8,true,6\n"
                             "4,9;8,0.95,0,7\n5,3,0.5,True,\n",
                         "2 1\n3 2 # trailing comment\n5 3\n\n"});
}

TEST_F(EvalAgainstReference, NoAcceptedNoTimesNoLoops) {
  expectSameAsReference({"nothing", "frame,candidate_frames,score,accepted\n0,,0,0\n1,0,0.5,0\n",
                         "# no loops at all\n"});
}

TEST_F(EvalAgainstReference, WindowAndPercentileTies) {
  // Six times: p50 index round(2.5) = 2 (half to even), p99 round(4.95) = 5.
  expectSameAsReference(
      {"window",
       std::string(kHeader) +
           "0,,0,0,6\n1,,0,0,1\n2,,0,0,5\n3,0,0.2,1,2\n4,10,0.3,1,4\n5,30,0.9,0,3\n",
       "3 5\n4 1\n5 12\n", 3});
}

TEST_F(EvalAgainstReference, RandomLogs) {
  std::mt19937 random(2024);
  for (int trial = 0; trial < 12; ++trial) {
    int frames = 20 + static_cast<int>(random() % 80);
    std::string log = kHeader, gt;
    for (int q = 0; q < frames; ++q) {
      std::string cands;
      int count = q > 0 ? static_cast<int>(random() % 4) : 0;
      for (int k = 0; k < count; ++k)
        cands += (k ? (random() % 2 ? " " : ";") : "") + std::to_string(random() % q);
      double score = std::round(std::uniform_real_distribution<double>(0, 1)(random) * 1000) / 1000;
      double time = std::uniform_real_distribution<double>(1, 100)(random);
      log += std::to_string(q) + "," + cands + "," + std::to_string(score) + "," +
             (random() % 3 == 0 ? "1" : "0") + "," + std::to_string(time) + "\n";
      if (q > 5 && random() % 2)
        gt += std::to_string(q) + " " + std::to_string(random() % q) + "\n";
    }
    expectSameAsReference(
        {"random" + std::to_string(trial), log, gt, static_cast<int>(random() % 3) * 2});
  }
}

TEST(PythonCompatibility, RoundingAndRepr) {
  EXPECT_EQ(pythonRepr(100.0), "100.0");
  EXPECT_EQ(pythonRepr(66.67), "66.67");
  EXPECT_EQ(pythonRepr(1e16), "1e+16");
  EXPECT_EQ(pythonRepr(1e-05), "1e-05");
  EXPECT_EQ(pythonRepr(std::nan("")), "nan");
  EXPECT_EQ(pythonRound2(0.125), 0.12);  // exact tie: half to even
  EXPECT_EQ(pythonRound2(2.675), 2.67);  // 2.675 is 2.67499999... in binary
  EXPECT_EQ(pythonRound2(200.0 / 3.0), 66.67);
  EXPECT_EQ(pythonPercentile({4, 1, 3, 2}, 50), 3);        // index round(1.5) = 2
  EXPECT_EQ(pythonPercentile({1, 2, 3, 4, 5, 6}, 50), 3);  // index round(2.5) = 2
}

TEST(PrecisionRecall, CurveOverThresholds) {
  CsvTable log;
  log.header = {"frame", "candidate_frames", "score", "accepted"};
  log.rows = {{"0", "", "0", "0"},
              {"1", "0", "0.9", "1"},
              {"2", "0", "0.8", "1"},
              {"3", "1", "0.5", "0"},
              {"4", "2", "0.5", "0"}};
  GroundTruth gt = {{1, {0}}, {3, {1}}, {4, {9}}};
  Evaluation eval = evaluate(log, gt, 0);
  ASSERT_EQ(eval.pr_curve.size(), 3u);
  EXPECT_DOUBLE_EQ(eval.pr_curve[0].threshold, 0.9);
  EXPECT_DOUBLE_EQ(eval.pr_curve[0].precision, 1.0);
  EXPECT_DOUBLE_EQ(eval.pr_curve[0].recall, 1.0 / 3);
  EXPECT_DOUBLE_EQ(eval.pr_curve[1].precision, 0.5);  // frame 2 has no loop: wrong
  // The tie at 0.5 is declared together: frames 3 (right) and 4 (wrong).
  EXPECT_DOUBLE_EQ(eval.pr_curve[2].precision, 0.5);
  EXPECT_DOUBLE_EQ(eval.pr_curve[2].recall, 2.0 / 3);
  EXPECT_DOUBLE_EQ(eval.figures.wrong_bar, 0.8);
}

// A log with a frame twice is refused, naming the frame: it would score a loop twice.
TEST(EvalRefusals, AFrameTwiceIsRefused) {
  CsvTable log;
  log.header = {"frame", "candidate_frames", "score", "accepted", "time_ms"};
  log.rows = {{"0", "", "0", "0", "10"}, {"1", "0", "0.9", "1", "10"}, {"1", "0", "0.9", "1", "9"}};
  try {
    evaluate(log, {{1, {0}}}, 0);
    ADD_FAILURE() << "a log with frame 1 twice was scored";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find("frame 1 appears twice"), std::string::npos) << e.what();
  }
}

// A bad frame's figures are gaps (NaN) in the plotted series, not zeros; its time stays.
TEST(RunSeries, BadFramesAreGapsNotZeros) {
  CsvTable log;
  log.header = {"frame",           "candidate_frames", "score",
                "accepted",        "time_ms",          "outcome",
                "vocabulary_size", "wm_size",          "mean_quantisation_error"};
  log.rows = {{"0", "", "0", "0", "10", "new", "100", "0", "0.1"},
              {"1", "", "0", "0", "4", "bad", "0", "0", "0"},
              {"2", "", "0.5", "0", "12", "new", "180", "1", "0.2"}};
  const Evaluation eval = evaluate(log, {}, 0);
  const RunSeries series = buildRunSeries(log, eval, {});
  ASSERT_EQ(series.frame.size(), 3u);
  for (const auto* values :
       {&series.score, &series.vocabulary_size, &series.wm_size, &series.mean_quantisation_error}) {
    ASSERT_EQ(values->size(), 3u);
    EXPECT_TRUE(std::isnan((*values)[1]));
    EXPECT_FALSE(std::isnan((*values)[2]));
  }
  EXPECT_DOUBLE_EQ(series.vocabulary_size[2], 180);
  EXPECT_DOUBLE_EQ(series.time_ms[1], 4);
}

// Accepted closures split into right and wrong; a loop frame without a right closure is missed;
// the filter's stage excludes the geometric check, which is a stage of its own.
TEST(RunSeries, RightWrongMissedAndStages) {
  CsvTable log;
  log.header = {"frame",   "candidate_frames", "score",     "accepted",        "time_ms",
                "outcome", "features_ms",      "filter_ms", "verification_ms", "storage_ms"};
  log.rows = {{"0", "", "0", "0", "5", "new", "2", "1", "0", "1"},
              {"1", "0", "0.9", "1", "9", "new", "3", "4", "3", "2"},
              {"2", "0", "0.8", "1", "9", "merged", "3", "4", "1", "2"},
              {"3", "", "0", "0", "1", "bad", "1", "0", "0", "0"},
              {"4", "1", "0.2", "0", "7", "new", "3", "2", "1", "2"}};
  const GroundTruth gt = {{1, {0}}, {3, {0}}, {4, {1}}};
  const Evaluation eval = evaluate(log, gt, 0);
  const RunSeries series = buildRunSeries(log, eval, gt);
  EXPECT_EQ(series.accepted_right, std::vector<double>({1}));
  EXPECT_EQ(series.accepted_wrong, std::vector<double>({2}));  // frame 2 has no loop
  EXPECT_EQ(series.gt_loop_frames, std::vector<double>({1, 3, 4}));
  EXPECT_EQ(series.missed_loops, std::vector<double>({3, 4}));  // 4 was right but not accepted
  std::vector<std::string> names;
  for (const auto& stage : series.stages) names.push_back(stage.name);
  EXPECT_EQ(names, std::vector<std::string>({"features", "filter", "verification", "storage"}));
  EXPECT_DOUBLE_EQ(series.stages[1].ms[1], 1.0);  // filter 4 less verification 3
  for (const auto& stage : series.stages) EXPECT_TRUE(std::isnan(stage.ms[3])) << stage.name;

  const auto dir = scratchDir("RunSeries_plots");
  std::vector<std::string> files;
  for (const auto& plot : writePlots(series, eval, dir)) files.push_back(plot.file);
  for (const char* png : {"precision_recall.png", "score.png", "time_by_stage.png"}) {
    EXPECT_NE(std::find(files.begin(), files.end(), png), files.end()) << png;
    EXPECT_FALSE(cv::imread((dir / png).string()).empty()) << png;
  }
}

// Frame 8 revisits 1 (found), 9 revisits 2 (missed; 9 took 5 instead): white, green, red pixels.
TEST(LoopMatrix, MarksMissedRightAndWrongPairs) {
  Evaluation eval;
  for (std::int64_t f = 0; f < 10; ++f) eval.frames.push_back({f, {}, 0, false, false, {}});
  eval.frames[8] = {8, {1}, 0.9, true, true, {}};
  eval.frames[9] = {9, {5}, 0.8, true, false, {}};
  GroundTruth gt = {{8, {1}}, {9, {2}}};
  const auto dir = scratchDir("LoopMatrix");
  const WrittenPlot plot = writeLoopMatrix(eval, gt, dir);
  const cv::Mat image = cv::imread((dir / plot.file).string(), cv::IMREAD_COLOR);
  ASSERT_EQ(image.size(), cv::Size(10, 10));
  EXPECT_EQ(image.at<cv::Vec3b>(9, 2), cv::Vec3b(255, 255, 255));  // missed
  EXPECT_EQ(image.at<cv::Vec3b>(8, 1), cv::Vec3b(0, 200, 0));      // right
  EXPECT_EQ(image.at<cv::Vec3b>(9, 5), cv::Vec3b(0, 0, 255));      // wrong
  EXPECT_EQ(image.at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 0));
}

// Without ground truth the matrix holds the accepted closures alone, one colour, no verdict.
TEST(LoopMatrix, WithoutGroundTruthShowsTheAcceptedClosuresUnjudged) {
  Evaluation eval;
  for (std::int64_t f = 0; f < 10; ++f) eval.frames.push_back({f, {}, 0, false, false, {}});
  eval.frames[8] = {8, {1, 2}, 0.9, true, false, {}};
  eval.frames[9] = {9, {5}, 0.3, false, false, {}};  // not accepted: not drawn
  const auto dir = scratchDir("LoopMatrix_unjudged");
  const WrittenPlot plot = writeLoopMatrix(eval, {}, dir, /*judged=*/false);
  EXPECT_NE(plot.what.find("no ground truth"), std::string::npos) << plot.what;
  const cv::Mat image = cv::imread((dir / plot.file).string(), cv::IMREAD_COLOR);
  ASSERT_EQ(image.size(), cv::Size(10, 10));
  const cv::Vec3b yellow(0, 220, 255), black(0, 0, 0);
  EXPECT_EQ(image.at<cv::Vec3b>(8, 1), yellow);
  EXPECT_EQ(image.at<cv::Vec3b>(8, 2), yellow);
  EXPECT_EQ(image.at<cv::Vec3b>(9, 5), black);
  EXPECT_EQ(cv::countNonZero(image.reshape(1)), 4) << "two yellow pixels, nothing else";
}

// A long run is shrunk, and a wrong closure sharing a pixel with a right one stays visible.
TEST(LoopMatrix, ShrinksLongRunsWithoutHidingWrongClosures) {
  Evaluation eval;
  eval.frames.push_back({2500, {10}, 0.9, true, true, {}});
  eval.frames.push_back({2501, {11}, 0.9, true, false, {}});
  const auto dir = scratchDir("LoopMatrix_long");
  const WrittenPlot plot = writeLoopMatrix(eval, {{2500, {10}}}, dir);
  const cv::Mat image = cv::imread((dir / plot.file).string(), cv::IMREAD_COLOR);
  EXPECT_LE(image.cols, kLoopMatrixMaxSide);
  EXPECT_EQ(image.rows, image.cols);
  EXPECT_EQ(image.at<cv::Vec3b>(2500 / 3, 10 / 3), cv::Vec3b(0, 0, 255));
}

}  // namespace
}  // namespace placedb::cli
