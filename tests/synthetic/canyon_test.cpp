#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <thread>

#include <opencv2/imgproc.hpp>

#include "placedb/error.h"
#include "synthetic/canyon.h"
#include "synthetic/synthetic_sequence.h"

namespace placedb::synthetic {
namespace {

SyntheticOptions walk(const std::string& scene, const std::string& lookalike = "none",
                      int frames = 60) {
  SyntheticOptions o = sceneDefaults(scene);
  o.frames = frames;
  o.width = 160;
  o.height = 120;
  o.lookalike = lookalike;
  return o;
}

// A camera that does not sway, so that every surface's edge lies where geometry puts it.
SyntheticOptions still(const std::string& scene) {
  SyntheticOptions o = walk(scene);
  o.width = 320;
  o.height = 240;
  o.hfov_degrees = 90;
  o.pitch_degrees = 0;
  o.lateral_wander = o.heading_wander_degrees = o.pitch_wander_degrees = o.height_wander = 0;
  return o;
}

int surfaceAt(const cv::Mat& ids, double u, double v) {
  return ids.at<std::uint8_t>(static_cast<int>(std::lround(v)), static_cast<int>(std::lround(u)));
}

constexpr int kFloor = static_cast<int>(CanyonSurface::kFloor);
constexpr int kLeft = static_cast<int>(CanyonSurface::kLeft);
constexpr int kRight = static_cast<int>(CanyonSurface::kRight);
constexpr int kTop = static_cast<int>(CanyonSurface::kTop);
constexpr int kEnd = static_cast<int>(CanyonSurface::kEnd);

TEST(Canyon, SameOptionsGiveTheSameBytesInAnyOrder) {
  const SyntheticSequence a(walk("corridor", "corridor")), b(walk("corridor", "corridor"));
  EXPECT_TRUE(a.groundTruth().empty());
  const cv::Mat late = b.render(50);  // b renders in another order
  for (int i : {0, 17, 50}) {
    EXPECT_EQ(cv::norm(a.render(i), i == 50 ? late : b.render(i), cv::NORM_INF), 0) << i;
  }
  EXPECT_EQ(cv::norm(a.render(17), a.render(17), cv::NORM_INF), 0);
  // Two threads rendering at once read the same world.
  cv::Mat from_thread;
  std::thread other_thread([&] { from_thread = a.render(33); });
  const cv::Mat here = a.render(33);
  other_thread.join();
  EXPECT_EQ(cv::norm(here, from_thread, cv::NORM_INF), 0);
  SyntheticOptions other = walk("corridor", "corridor");
  other.seed = 2;
  EXPECT_GT(cv::norm(a.renderClean(17), SyntheticSequence(other).renderClean(17), cv::NORM_L1) /
                (160 * 120),
            4);
}

TEST(Canyon, TheCorridorLiesWhereGeometryPutsIt) {
  const SyntheticOptions o = still("corridor");
  const SyntheticSequence s(o);
  const CanyonWorld& world = *s.canyon();
  const CameraIntrinsics& c = s.camera();
  const Pose p = s.pose(0);
  const cv::Mat ids = world.surfaces(p, c);
  const CanyonBox& box = world.box();
  // Straight ahead, the end wall; its edges where its corners project.
  const double ahead = box.x_end - p.x;
  EXPECT_EQ(surfaceAt(ids, c.cx, c.cy), kEnd);
  const double floor_edge = c.cy + c.focal * p.height / ahead;
  const double ceiling_edge = c.cy - c.focal * (box.height - p.height) / ahead;
  const double left_edge = c.cx - c.focal * box.y_left / ahead;
  const double right_edge = c.cx - c.focal * box.y_right / ahead;
  EXPECT_EQ(surfaceAt(ids, c.cx, floor_edge - 1.5), kEnd);
  EXPECT_EQ(surfaceAt(ids, c.cx, floor_edge + 1.5), kFloor);
  EXPECT_EQ(surfaceAt(ids, c.cx, ceiling_edge + 1.5), kEnd);
  EXPECT_EQ(surfaceAt(ids, c.cx, ceiling_edge - 1.5), kTop);
  EXPECT_EQ(surfaceAt(ids, left_edge + 1.5, c.cy), kEnd);
  EXPECT_EQ(surfaceAt(ids, left_edge - 1.5, c.cy), kLeft);
  EXPECT_EQ(surfaceAt(ids, right_edge - 1.5, c.cy), kEnd);
  EXPECT_EQ(surfaceAt(ids, right_edge + 1.5, c.cy), kRight);
  // The floor along the bottom rows, the ceiling along the top, the walls to the sides.
  EXPECT_EQ(surfaceAt(ids, c.cx, c.height - 1), kFloor);
  EXPECT_EQ(surfaceAt(ids, c.cx, 0), kTop);
  EXPECT_EQ(surfaceAt(ids, 0, c.cy), kLeft);
  EXPECT_EQ(surfaceAt(ids, c.width - 1, c.cy), kRight);
  // A wall meets the floor where the wall's foot projects: 3 m ahead on the left.
  const double foot_u = c.cx - c.focal * box.y_left / 3.0, foot_v = c.cy + c.focal * p.height / 3.0;
  EXPECT_EQ(surfaceAt(ids, foot_u - 3, foot_v - 3), kLeft);
  EXPECT_EQ(surfaceAt(ids, foot_u + 3, foot_v + 3), kFloor);

  // The image: a ceiling brighter than the floor, as the corridor's looks say, and every part
  // textured (nothing flat but the start wall, which is never in view).
  const cv::Mat image = s.renderClean(0);
  cv::Scalar floor_mean, floor_sd, top_mean, top_sd;
  cv::meanStdDev(image, floor_mean, floor_sd, ids == kFloor);
  cv::meanStdDev(image, top_mean, top_sd, ids == kTop);
  EXPECT_GT(top_mean[0], floor_mean[0] + 40);
  EXPECT_GT(floor_sd[0], 3);
  EXPECT_GT(top_sd[0], 1);
}

TEST(Canyon, TheStreetHasAnEmptySkyAboveItsFacades) {
  const SyntheticOptions o = still("street");
  const SyntheticSequence s(o);
  const CameraIntrinsics& c = s.camera();
  const cv::Mat ids = s.canyon()->surfaces(s.pose(0), c);
  const CanyonBox& box = s.canyon()->box();
  EXPECT_TRUE(box.sky);
  EXPECT_LT(box.y_right, 0);
  EXPECT_GT(box.y_left, -box.y_right);  // the walk keeps to the right-hand pavement
  EXPECT_EQ(surfaceAt(ids, c.cx, 0), kTop);
  EXPECT_EQ(surfaceAt(ids, c.cx, c.height - 1), kFloor);
  EXPECT_EQ(surfaceAt(ids, c.width - 1, c.cy), kRight);
  EXPECT_EQ(surfaceAt(ids, c.cx, c.cy), kEnd);
  // The sky is one flat grey, away from its edges; the facades are not.
  cv::Mat sky = ids == kTop, facades = (ids == kLeft) | (ids == kRight);
  cv::erode(sky, sky, cv::Mat(), cv::Point(-1, -1), 2);
  ASSERT_GT(cv::countNonZero(sky), 1000);
  const cv::Mat image = s.renderClean(0);
  cv::Scalar mean, sd;
  cv::meanStdDev(image, mean, sd, sky);
  EXPECT_EQ(sd[0], 0);
  cv::meanStdDev(image, mean, sd, facades);
  EXPECT_GT(sd[0], 20);
}

TEST(Canyon, OnePosterStandsAtTwoPlacesOnOneWall) {
  const SyntheticOptions o = walk("corridor", "poster", 200);
  const SyntheticSequence s(o);
  const std::vector<WallDecal>& decals = s.canyon()->decals();
  ASSERT_EQ(decals.size(), 2u);
  EXPECT_EQ(decals[0].picture, decals[1].picture);
  EXPECT_EQ(decals[0].side, decals[1].side);
  EXPECT_NEAR(decals[1].x - decals[0].x, o.lookalike_gap * o.speed, 1e-9);
  // Upright at eye level, at the size of a poster.
  EXPECT_NEAR(decals[0].bottom + 0.5 * decals[0].picture->height(), 1.5, 0.01);
  EXPECT_NEAR(decals[0].picture->width(), 1.0, 0.01);
  EXPECT_NEAR(decals[0].picture->height(), 1.4, 0.01);
  // The frames at both places show it, the last frame (both behind it) does not.
  const SyntheticSequence plain(walk("corridor", "none", 200));
  for (int frame : {s.size() / 3, s.size() / 3 + o.lookalike_gap}) {
    EXPECT_GT(cv::norm(s.renderClean(frame), plain.renderClean(frame), cv::NORM_L1), 2e4)
        << "frame " << frame;
  }
  EXPECT_EQ(cv::norm(s.renderClean(199), plain.renderClean(199), cv::NORM_INF), 0);
}

TEST(Canyon, DoorsAndLockersRepeatAtTheirPitchOnBothWalls) {
  SyntheticOptions o = walk("corridor", "corridor");
  o.lookalike_pitch = 4.0;
  const SyntheticSequence s(o);
  const std::vector<WallDecal>& decals = s.canyon()->decals();
  const CanyonBox& box = s.canyon()->box();
  ASSERT_GE(decals.size(), 2 * static_cast<std::size_t>((box.x_end - box.x_start) / 4.0) - 2);
  int left = 0, right = 0;
  for (std::size_t i = 0; i < decals.size(); ++i) {
    EXPECT_EQ(decals[i].picture, decals[0].picture);
    EXPECT_EQ(decals[i].bottom, 0);  // standing on the floor
    (decals[i].side == WallSide::kLeft ? left : right) += 1;
    if (i >= 2) {
      EXPECT_NEAR(decals[i].x - decals[i - 2].x, 4.0, 1e-9);
    }
  }
  EXPECT_EQ(left, right);
  // A door (2.1 m) and lockers, wider than tall: a stretch of wall at its real size.
  EXPECT_GT(decals[0].picture->height(), 2.1);
  EXPECT_GT(decals[0].picture->width(), 2.0);
  // They are in every view: the walls differ from the same corridor's without them.
  const SyntheticSequence plain(walk("corridor", "none"));
  for (int frame : {0, 30, 59}) {
    EXPECT_GT(cv::norm(s.renderClean(frame), plain.renderClean(frame), cv::NORM_L1),
              20.0 * 160 * 120 / 4)
        << "frame " << frame;
  }
}

TEST(Canyon, RefusesWhatItCannotShow) {
  const auto refused = [](const SyntheticOptions& o, const std::string& words) {
    try {
      const SyntheticSequence s(o);
      ADD_FAILURE() << "accepted, expected: " << words;
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  SyntheticOptions o = walk("corridor");
  o.profile = "demo";  // a box has no streets to come back along
  refused(o, "single_pass");
  o = walk("corridor");
  o.camera_height = 3.0;  // above the ceiling
  refused(o, "camera_height");
  o = walk("corridor");
  o.pitch_degrees = 60;  // the floor and nothing else
  refused(o, "horizon");
  o = walk("corridor");
  o.lateral_wander = 1.2;  // through the walls
  refused(o, "side walls");
  o = walk("street");
  o.canyon_walk_offset = -6;  // in the facade
  refused(o, "side walls");
  o = walk("corridor");
  o.lookalike = "statue";
  refused(o, "statue");
  o = walk("corridor");
  o.scene = "cave";
  refused(o, "cave");
  EXPECT_THROW(sceneDefaults("cave"), Error);
  // A canyon has no ground footprint and no homography between frames.
  const SyntheticSequence s(walk("corridor", "none", 10));
  EXPECT_THROW(s.footprint(0), Error);
  EXPECT_THROW(s.homography(0, 1), Error);
}

TEST(Canyon, TheGroundSceneKeepsItsDefaults) {
  const SyntheticOptions ground = sceneDefaults("ground"), plain;
  EXPECT_EQ(ground.scene, "ground");
  EXPECT_EQ(ground.profile, plain.profile);
  EXPECT_EQ(ground.camera_height, plain.camera_height);
  EXPECT_EQ(ground.pitch_degrees, plain.pitch_degrees);
  EXPECT_EQ(ground.speed, plain.speed);
  EXPECT_EQ(SyntheticSequence(plain).canyon(), nullptr);
}

}  // namespace
}  // namespace placedb::synthetic
