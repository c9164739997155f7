#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "placedb/error.h"
#include "synthetic/synthetic_sequence.h"
#include "test_paths.h"

namespace placedb::synthetic {
namespace {

SyntheticOptions options(int frames, std::uint64_t seed, const std::string& profile = "demo") {
  SyntheticOptions o;
  o.frames = frames;
  o.seed = seed;
  o.profile = profile;
  return o;
}

double revisitShare(const SyntheticSequence& s) {
  return s.revisitingFrames() / static_cast<double>(s.size());
}

TEST(SyntheticSequence, SameSeedGivesIdenticalSequence) {
  const SyntheticSequence a(options(400, 7)), b(options(400, 7));
  EXPECT_EQ(a.groundTruth(), b.groundTruth());
  for (int i : {0, 137, 399}) {
    EXPECT_EQ(cv::norm(a.render(i), b.render(i), cv::NORM_INF), 0) << "frame " << i;
    EXPECT_EQ(a.pose(i).x, b.pose(i).x);
    EXPECT_EQ(a.pose(i).heading, b.pose(i).heading);
  }
  // Rendering order and repetition do not matter either.
  EXPECT_EQ(cv::norm(a.render(137), b.render(137), cv::NORM_INF), 0);
}

TEST(SyntheticSequence, DifferentSeedGivesDifferentSequence) {
  const SyntheticSequence a(options(400, 7)), b(options(400, 8));
  EXPECT_NE(a.groundTruth(), b.groundTruth());
  for (int i : {0, 200}) {
    EXPECT_GT(cv::norm(a.render(i), b.render(i), cv::NORM_L1) / a.render(i).total(), 15);
  }
}

TEST(SyntheticSequence, FramesHaveTheRequestedSizeAndFollowEachOther) {
  SyntheticOptions o = options(10, 1);
  o.width = 200;
  o.height = 150;
  const SyntheticSequence s(o);
  ASSERT_EQ(s.size(), 10);
  EXPECT_TRUE(s.groundTruth().empty());  // 10 frames cannot hold a loop 50 frames apart
  EXPECT_EQ(s.firstRevisit(), -1);
  for (int i = 0; i < s.size(); ++i) {
    const cv::Mat frame = s.render(i);
    EXPECT_EQ(frame.type(), CV_8UC1);
    EXPECT_EQ(frame.size(), cv::Size(200, 150));
    if (i > 0) {  // a steady drive: 0.6 m per frame
      const Pose p = s.pose(i), prev = s.pose(i - 1);
      EXPECT_NEAR(std::hypot(p.x - prev.x, p.y - prev.y), 0.6, 0.1);
    }
  }
  EXPECT_THROW(s.render(10), Error);
  EXPECT_THROW(s.pose(-1), Error);
}

TEST(SyntheticSequence, LongScaleRouteIsCheapToPlanAndRenders) {
  const SyntheticSequence s(options(20000, 3, "scale"));
  ASSERT_EQ(s.size(), 20000);
  const double share = revisitShare(s);
  EXPECT_GT(share, 0.15);
  EXPECT_LT(share, 0.55);
  // Revisits keep coming through the whole run, not only at one moment.
  for (int quarter = 1; quarter < 4; ++quarter) {
    int revisiting = 0;
    for (int q = quarter * 5000; q < (quarter + 1) * 5000; ++q)
      revisiting += !s.revisitsOf(q).empty();
    EXPECT_GT(revisiting, 200) << "quarter " << quarter;
  }
  // Some repeats reach far back in time: the memory-bounded case the profile is for.
  int long_gaps = 0;
  for (const auto& [q, r] : s.groundTruth()) long_gaps += q - r > 5000;
  EXPECT_GT(long_gaps, 100);
  for (int i : {0, 9999, 19999}) {
    cv::Scalar mean, stddev;
    cv::meanStdDev(s.render(i), mean, stddev);
    EXPECT_GT(stddev[0], 20) << "frame " << i;
  }
}

TEST(SyntheticSequence, DemoRevisitShareAndFirstRevisitFollowTheOptions) {
  for (std::uint64_t seed : {1, 2, 3}) {
    const SyntheticSequence s(options(1000, seed));
    EXPECT_GE(revisitShare(s), 0.3) << "seed " << seed;
    EXPECT_LE(revisitShare(s), 0.5) << "seed " << seed;
    EXPECT_GE(s.firstRevisit(), 280) << "seed " << seed;
    EXPECT_LE(s.firstRevisit(), 550) << "seed " << seed;
  }
  SyntheticOptions fewer = options(1000, 1);
  fewer.revisit_fraction = 0.2;
  fewer.first_revisit_fraction = 0.5;
  const SyntheticSequence s(fewer);
  EXPECT_GE(revisitShare(s), 0.1);
  EXPECT_LE(revisitShare(s), 0.3);
  EXPECT_GE(s.firstRevisit(), 430);
}

TEST(SyntheticSequence, WrittenSequenceParsesAndMatches) {
  const SyntheticSequence s(options(300, 1));
  ASSERT_FALSE(s.groundTruth().empty());
  const auto dir = placedb::testing::scratchDir("synthetic_write");
  int calls = 0, last_done = 0;
  writeSequence(s, dir, [&](int done, int total) {
    ++calls;
    EXPECT_EQ(total, 300);
    EXPECT_EQ(done, last_done + 1);
    last_done = done;
  });
  EXPECT_EQ(calls, 300);

  std::ifstream frames(dir / "frames.txt");
  std::vector<std::string> names;
  for (std::string line; std::getline(frames, line);) names.push_back(line);
  ASSERT_EQ(names.size(), 300u);
  EXPECT_EQ(names[0], "images/000000.png");
  EXPECT_EQ(names[299], "images/000299.png");
  for (int i : {0, 151, 299}) {
    const cv::Mat read = cv::imread((dir / names[i]).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(read.empty());
    EXPECT_EQ(cv::norm(read, s.render(i), cv::NORM_INF), 0);
  }

  std::ifstream pairs_file(dir / "gt_pairs.txt");
  std::string header;
  std::getline(pairs_file, header);
  EXPECT_EQ(header.rfind("# q r", 0), 0u);
  std::vector<std::pair<int, int>> pairs;
  for (std::string line; std::getline(pairs_file, line);) {
    std::istringstream fields(line);
    int q = -1, r = -1;
    ASSERT_TRUE(fields >> q >> r) << line;
    pairs.emplace_back(q, r);
  }
  EXPECT_EQ(pairs, s.groundTruth());
}

TEST(SyntheticSequence, FramesGiveDetectorsPlentyToFind) {
  const SyntheticSequence s(options(300, 4));
  auto orb = cv::ORB::create(3000);
  for (int i : {0, 60, 120, 180, 240}) {
    std::vector<cv::KeyPoint> keypoints;
    orb->detect(s.render(i), keypoints);
    EXPECT_GT(keypoints.size(), 300u) << "frame " << i;
  }
  auto kaze = cv::KAZE::create();  // Hessian blobs at several scales, the closest to SURF here
  for (int i : {30, 210}) {
    std::vector<cv::KeyPoint> keypoints;
    kaze->detect(s.render(i), keypoints);
    EXPECT_GT(keypoints.size(), 150u) << "frame " << i;
    // Structure at coarse scales too, not only fine texture.
    int coarse = 0, coarser = 0;
    for (const auto& k : keypoints) {
      coarse += k.octave >= 1;
      coarser += k.octave >= 2;
    }
    EXPECT_GT(coarse, 50) << "frame " << i;
    EXPECT_GT(coarser, 15) << "frame " << i;
  }
}

TEST(SyntheticSequence, RejectsImpossibleOptions) {
  auto expectInvalid = [](const SyntheticOptions& o) {
    try {
      SyntheticSequence s(o);
      ADD_FAILURE() << "accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    }
  };
  SyntheticOptions o = options(100, 1);
  o.profile = "tour";
  expectInvalid(o);
  o = options(0, 1);
  expectInvalid(o);
  o = options(100, 1);
  o.pitch_degrees = 25;  // the top of the image would see the horizon
  expectInvalid(o);
  o = options(100, 1);
  o.width = 4;
  expectInvalid(o);
}

}  // namespace
}  // namespace placedb::synthetic
