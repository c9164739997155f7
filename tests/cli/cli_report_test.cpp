// `placedb report` end to end: the page of a small synthetic run, and its refusals.
#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <regex>

#include "cli_scratch.h"

namespace placedb::testing {
namespace {

namespace fs = std::filesystem;

std::size_t countOf(const std::string& text, const std::string& what) {
  std::size_t count = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++count;
  return count;
}

class ReportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    data_ = smallSequence(200);  // the first loops come after 150 frames
    dir_ = data_.parent_path() / (data_.filename().string() + "_run");
    fs::create_directories(dir_);
    map_ = dir_ / "run.placedb";
    log_ = dir_ / "run.csv";
    gt_ = data_ / "gt_pairs.txt";
    auto mapped = placedb(
        {"map", map_.string(), (data_ / "frames.txt").string(), "--log", log_.string(), "--quiet"},
        dir_);
    ASSERT_EQ(mapped.exit_code, 0) << describe(mapped);
  }
  fs::path data_, dir_, map_, log_, gt_;
};

TEST_F(ReportTest, OnePageWithScoresFiguresAndClosures) {
  const fs::path out = dir_ / "report";
  auto r =
      placedb({"report", map_.string(), log_.string(), gt_.string(), "--out", out.string()}, dir_);
  ASSERT_EQ(r.exit_code, 0) << describe(r);
  EXPECT_NE(r.out.find((out / "index.html").string()), std::string::npos) << r.out;
  const std::string page = bytesOf(out / "index.html");
  ASSERT_FALSE(page.empty());
  // Everything is inside the page: only index.html in the folder, no image by reference.
  EXPECT_EQ(std::distance(fs::directory_iterator(out), fs::directory_iterator()), 1);
  const std::size_t images = countOf(page, "<img ");
  EXPECT_EQ(countOf(page, "<img src=\"data:image/"), images);
  for (const char* png :
       {"precision_recall.png", "score.png", "loop_matrix.png", "time_by_stage.png", "wm_size.png"})
    EXPECT_NE(page.find(std::string("alt=\"") + png + "\""), std::string::npos) << png;
  EXPECT_NE(page.find("recall_at_100_precision"), std::string::npos);
  EXPECT_NE(page.find("accepted_true"), std::string::npos);
  // The wrong closures come before the right ones; every right one has two thumbnails.
  const auto wrong = page.find("<h3>Wrong: "), right = page.find("<h3>Right: ");
  ASSERT_NE(wrong, std::string::npos);
  ASSERT_NE(right, std::string::npos);
  EXPECT_LT(wrong, right);
  std::smatch accepted;
  const std::string tail = page.substr(right);
  ASSERT_TRUE(std::regex_search(tail, accepted, std::regex("<h3>Right: (\\d+)</h3>")));
  const std::size_t shown = std::min<std::size_t>(std::stoul(accepted[1]), 24);
  EXPECT_GT(shown, 0u) << "the synthetic tour closes loops";
  EXPECT_EQ(countOf(tail, "<img src=\"data:image/jpeg"), 2 * shown);
  EXPECT_EQ(countOf(page, "class=\"missing\""), 0u);

  // Run again into the same folder: the page is replaced, nothing else appears.
  auto again = placedb({"report", map_.string(), log_.string(), gt_.string(), "--out", out.string(),
                        "--max-right", "2"},
                       dir_);
  ASSERT_EQ(again.exit_code, 0) << describe(again);
  EXPECT_EQ(countOf(bytesOf(out / "index.html"), "<div class=\"pair right\">"),
            std::min<std::size_t>(std::stoul(accepted[1]), 2));
}

// The thumbnails come from the session that wrote the log, not from the map's last session.
TEST_F(ReportTest, ThumbnailsOfTheLogsSession) {
  const fs::path copy = dir_ / "copy";
  fs::copy(data_, copy, fs::copy_options::recursive);
  auto second = placedb({"map", map_.string(), (copy / "frames.txt").string(), "--quiet"}, dir_);
  ASSERT_EQ(second.exit_code, 0) << describe(second);
  const fs::path out = dir_ / "first";
  auto r = placedb({"report", map_.string(), log_.string(), gt_.string(), "--out", out.string(),
                    "--max-right", "2"},
                   dir_);
  ASSERT_EQ(r.exit_code, 0) << describe(r);
  const std::string page = bytesOf(out / "index.html");
  EXPECT_NE(page.find("(session 1)"), std::string::npos);
  EXPECT_NE(page.find("title=\"" + data_.string()), std::string::npos);
  EXPECT_EQ(page.find(copy.string()), std::string::npos);
  auto other = placedb({"report", map_.string(), log_.string(), gt_.string(), "--out",
                        (dir_ / "second").string(), "--session", "2", "--max-right", "2"},
                       dir_);
  ASSERT_EQ(other.exit_code, 0) << describe(other);
  EXPECT_NE(bytesOf(dir_ / "second" / "index.html").find("title=\"" + copy.string()),
            std::string::npos);
}

// Without ground truth: exit 0, the closures shown without a verdict, no figure that would call
// them right or wrong, and the figures that need none: the score per frame and the matrix of the
// accepted closures, both with every closure in one colour (issue #50).
TEST_F(ReportTest, WithoutGroundTruthTheClosuresAreShownUnjudged) {
  const fs::path out = dir_ / "unjudged";
  auto r = placedb({"report", map_.string(), log_.string(), "--out", out.string()}, dir_);
  ASSERT_EQ(r.exit_code, 0) << describe(r);
  EXPECT_NE(r.out.find("not judged"), std::string::npos) << r.out;
  const std::string page = bytesOf(out / "index.html");
  std::smatch accepted;
  ASSERT_TRUE(std::regex_search(page, accepted, std::regex("Accepted loop closures: (\\d+)")));
  EXPECT_GT(std::stoul(accepted[1]), 0u);
  EXPECT_EQ(countOf(page, "<div class=\"pair unjudged\">"),
            std::min<std::size_t>(std::stoul(accepted[1]), 48 + 24));
  EXPECT_EQ(countOf(page, "pair wrong"), 0u);
  EXPECT_EQ(countOf(page, "pair right"), 0u);
  EXPECT_EQ(page.find("precision_recall.png"), std::string::npos);
  EXPECT_NE(page.find("time_by_stage.png"), std::string::npos);
  EXPECT_NE(page.find("score.png"), std::string::npos);
  EXPECT_NE(page.find("no ground truth"), std::string::npos);
  // The matrix: one yellow pixel per accepted closure (none white, green or red).
  EXPECT_NE(page.find("loop_matrix.png"), std::string::npos);
  EXPECT_NE(page.find("in yellow"), std::string::npos);
  EXPECT_EQ(countOf(page, "class=\"missing\""), 0u);
}

// A second session over the same images closes loops on the first: the report of its log shows
// them, with the first session's thumbnails, whether or not a ground truth is given.
TEST_F(ReportTest, ClosuresToOtherSessionsAreListed) {
  const fs::path log2 = dir_ / "second.csv";
  auto second = placedb({"map", map_.string(), (data_ / "frames.txt").string(), "--log",
                         log2.string(), "--quiet", "--stop-after", "60"},
                        dir_);
  ASSERT_EQ(second.exit_code, 0) << describe(second);
  for (const bool with_gt : {false, true}) {
    const fs::path out = dir_ / (with_gt ? "second_gt" : "second");
    std::vector<std::string> args = {"report", map_.string(), log2.string()};
    if (with_gt) args.push_back(gt_.string());
    args.insert(args.end(), {"--out", out.string()});
    auto r = placedb(args, dir_);
    ASSERT_EQ(r.exit_code, 0) << describe(r);
    const std::string page = bytesOf(out / "index.html");
    std::smatch others;
    ASSERT_TRUE(std::regex_search(page, others, std::regex("Closures to other sessions: (\\d+)")))
        << "with_gt " << with_gt;
    EXPECT_GT(std::stoul(others[1]), 10u);
    EXPECT_NE(page.find("&rarr; session 1 frame "), std::string::npos);
    EXPECT_EQ(countOf(page, "class=\"missing\""), 0u);
  }
}

// Frames of a video: their thumbnails are read from the video at the stored frame index.
TEST_F(ReportTest, ThumbnailsOfAVideoSource) {
  const fs::path video = dir_ / "tour.avi";
  {
    cv::VideoWriter writer(video.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10,
                           cv::Size(240, 180));
    ASSERT_TRUE(writer.isOpened());
    for (int i = 0; i < 200; ++i) {
      char name[32];
      std::snprintf(name, sizeof name, "images/%06d.png", i);
      writer.write(cv::imread((data_ / name).string()));
    }
  }
  const fs::path map = dir_ / "video.placedb", log = dir_ / "video.csv";
  ASSERT_EQ(
      placedb({"map", map.string(), video.string(), "--log", log.string(), "-q"}, dir_).exit_code,
      0);
  const fs::path out = dir_ / "video_report";
  auto r = placedb({"report", map.string(), log.string(), "--out", out.string()}, dir_);
  ASSERT_EQ(r.exit_code, 0) << describe(r);
  EXPECT_EQ(r.err.find("could not be read"), std::string::npos) << r.err;
  const std::string page = bytesOf(out / "index.html");
  EXPECT_GT(countOf(page, "<div class=\"pair unjudged\">"), 0u);
  EXPECT_EQ(countOf(page, "class=\"missing\""), 0u);
}

// A page the disk has no room for is exit 7 and leaves no file, whole or partial.
TEST_F(ReportTest, FullDiskLeavesNoPage) {
  TinyDisk disk(dir_ / "disk", "64k");
  if (!disk.mounted()) GTEST_SKIP() << "cannot mount a tmpfs here (needs CAP_SYS_ADMIN)";
  const fs::path out = dir_ / "disk" / "report";
  auto r =
      placedb({"report", map_.string(), log_.string(), gt_.string(), "--out", out.string()}, dir_);
  expectCleanError(r, 7, (out / "index.html").string());
  ASSERT_TRUE(fs::is_directory(out));
  EXPECT_EQ(std::distance(fs::directory_iterator(out), fs::directory_iterator()), 0);
}

TEST_F(ReportTest, RefusalsNameTheFileAndWriteNothing) {
  const fs::path out = dir_ / "refused";
  auto report = [&](const fs::path& map, const fs::path& log, const fs::path& gt,
                    const fs::path& where) {
    return placedb({"report", map.string(), log.string(), gt.string(), "--out", where.string()},
                   dir_);
  };
  expectCleanError(report(map_, log_, dir_ / "nope.txt", out), 3, "nope.txt");
  expectCleanError(report(dir_ / "nope.placedb", log_, gt_, out), 3, "nope.placedb");
  expectCleanError(report(map_, dir_, gt_, out), 3, "folder");
  std::ofstream(dir_ / "not_a_map.placedb") << "not a map";
  expectCleanError(report(dir_ / "not_a_map.placedb", log_, gt_, out), 4, "not_a_map.placedb");
  std::ofstream(dir_ / "bare.csv") << "frame,score\n0,0\n";
  expectCleanError(report(map_, dir_ / "bare.csv", gt_, out), 2, "candidate_frames");
  EXPECT_FALSE(fs::exists(out));
  std::ofstream(dir_ / "a_file") << "x";
  expectCleanError(report(map_, log_, gt_, dir_ / "a_file"), 3, "a_file");
  EXPECT_EQ(bytesOf(dir_ / "a_file"), "x");

  auto help = placedb({"report", "--help"}, dir_);
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.out.find("Examples:"), std::string::npos);
  EXPECT_NE(help.out.find("Exit status"), std::string::npos);
}

}  // namespace
}  // namespace placedb::testing
