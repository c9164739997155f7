#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "placedb/error.h"
#include "synthetic/lookalikes.h"
#include "synthetic/synthetic_sequence.h"

namespace placedb::synthetic {
namespace {

SyntheticOptions walk(const std::string& lookalike, int frames = 200) {
  SyntheticOptions o;
  o.profile = "single_pass";
  o.lookalike = lookalike;
  o.frames = frames;
  o.width = 320;
  o.height = 180;
  o.speed = 0.5;
  o.camera_height = 1.5;
  o.pitch_degrees = 30;
  return o;
}

TEST(Lookalikes, ASinglePassNeverComesBack) {
  const SyntheticSequence s(walk("none", 600));
  EXPECT_TRUE(s.groundTruth().empty());
  EXPECT_EQ(s.firstRevisit(), -1);
  // It goes straight on: the last frame is as far from the first as the walk is long.
  EXPECT_NEAR(std::hypot(s.pose(599).x - s.pose(0).x, s.pose(599).y - s.pose(0).y), 599 * 0.5, 2.0);
}

TEST(Lookalikes, OnePosterStandsAtTwoPlacesAsTheSamePicture) {
  const SyntheticOptions o = walk("poster");
  const SyntheticSequence s(o);
  std::vector<Pose> poses;
  for (int i = 0; i < s.size(); ++i) poses.push_back(s.pose(i));
  const std::vector<Decal> decals = placeLookalikes(o, poses);
  ASSERT_EQ(decals.size(), 2u);
  EXPECT_EQ(decals[0].picture, decals[1].picture);
  const double apart =
      std::hypot(decals[1].centre.x - decals[0].centre.x, decals[1].centre.y - decals[0].centre.y);
  EXPECT_NEAR(apart, o.lookalike_gap * o.speed, 1.0);
  // Both places show it: the frames there differ from the same walk without it.
  const SyntheticSequence plain(walk("none"));
  for (int frame : {s.size() / 3, s.size() / 3 + o.lookalike_gap})
    EXPECT_GT(cv::norm(s.renderClean(frame), plain.renderClean(frame), cv::NORM_L1), 1e5)
        << "frame " << frame;
  // ... and the frames half way between do not.
  const int between = s.size() / 3 + o.lookalike_gap / 2;
  EXPECT_EQ(cv::norm(s.renderClean(between), plain.renderClean(between), cv::NORM_INF), 0);
}

TEST(Lookalikes, CorridorDoorsRepeatAtTheirPitchOnBothSides) {
  SyntheticOptions o = walk("corridor");
  o.lookalike_pitch = 4.0;
  const SyntheticSequence s(o);
  std::vector<Pose> poses;
  for (int i = 0; i < s.size(); ++i) poses.push_back(s.pose(i));
  const std::vector<Decal> decals = placeLookalikes(o, poses);
  ASSERT_GE(decals.size(), 40u);  // 100 m of walk, a pair every 4 m
  for (std::size_t i = 2; i + 1 < decals.size(); i += 2) {
    EXPECT_EQ(decals[i].picture, decals[0].picture);
    EXPECT_NEAR(std::hypot(decals[i].centre.x - decals[i - 2].centre.x,
                           decals[i].centre.y - decals[i - 2].centre.y),
                4.0, 0.6);
  }
}

TEST(Lookalikes, AnUnknownKindIsRefused) {
  try {
    const SyntheticSequence s(walk("statue"));
    FAIL() << "accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find("statue"), std::string::npos);
  }
}

TEST(Lookalikes, ABlanderFloorKeepsItsMidGrey) {
  SyntheticOptions o = walk("none");
  o.ground_contrast = 0.2;
  const SyntheticSequence bland(o), plain(walk("none"));
  cv::Scalar mean_bland, sd_bland, mean_plain, sd_plain;
  cv::meanStdDev(bland.renderClean(10), mean_bland, sd_bland);
  cv::meanStdDev(plain.renderClean(10), mean_plain, sd_plain);
  EXPECT_LT(sd_bland[0], 0.3 * sd_plain[0]);
  EXPECT_NEAR(mean_bland[0], 128 + 0.2 * (mean_plain[0] - 128), 2.0);
}

}  // namespace
}  // namespace placedb::synthetic
