#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include <opencv2/imgproc.hpp>

#include "synthetic/ground_truth.h"
#include "synthetic/seeded_random.h"
#include "synthetic/synthetic_sequence.h"

namespace placedb::synthetic {
namespace {

SyntheticOptions demoOptions(int frames, std::uint64_t seed) {
  SyntheticOptions options;
  options.frames = frames;
  options.seed = seed;
  return options;
}

// Normalised cross-correlation of two images over a mask.
double maskedNcc(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask) {
  cv::Scalar mean_a, std_a, mean_b, std_b;
  cv::meanStdDev(a, mean_a, std_a, mask);
  cv::meanStdDev(b, mean_b, std_b, mask);
  cv::Mat fa, fb;
  a.convertTo(fa, CV_64F, 1, -mean_a[0]);
  b.convertTo(fb, CV_64F, 1, -mean_b[0]);
  const double covariance = cv::mean(fa.mul(fb), mask)[0];
  return covariance / (std_a[0] * std_b[0] + 1e-9);
}

TEST(GroundTruth, SpatialHashFindsExactlyWhatBruteForceFinds) {
  const SyntheticSequence sequence(demoOptions(700, 3));
  std::vector<Pose> poses;
  for (int i = 0; i < sequence.size(); ++i) poses.push_back(sequence.pose(i));
  const GroundTruthSettings settings;  // the same definition as the sequence's defaults
  std::vector<std::pair<int, int>> brute;
  int opposite = 0;  // pairs driven more than 90 degrees apart
  for (int q = 0; q < sequence.size(); ++q) {
    for (int r = 0; q - r >= settings.min_gap; ++r) {
      const auto a = sequence.footprint(q), b = sequence.footprint(r);
      const double shared = footprintIntersection(a, b) / std::min(polygonArea(a), polygonArea(b));
      if (shared >= settings.min_shared) {
        brute.emplace_back(q, r);
        opposite += headingDifference(poses[q].heading, poses[r].heading) > CV_PI / 2;
      }
    }
  }
  ASSERT_FALSE(brute.empty());
  EXPECT_GT(opposite, 0) << "the route should drive some street the other way";
  EXPECT_EQ(computeRevisits(poses, sequence.camera(), settings), brute);
  EXPECT_EQ(sequence.groundTruth(), brute);
}

// The demo's tour (300 frames, seed 1) ends by driving back up the street it started on: frames
// 177-188 approach frame 0 and see the ground of frames 0-11 from behind them, in the same
// direction, before the camera reaches the start (frame 189 stands where frame 0 stood). The
// engine closes loops from frame 179 on, and they are right: the rule lists these pairs.
TEST(GroundTruth, DemoTourApproachingItsStartRevisitsIt) {
  const SyntheticSequence sequence(demoOptions(300, 1));
  for (int q = 179; q <= 188; ++q) {
    const auto refs = sequence.revisitsOf(q);
    ASSERT_FALSE(refs.empty()) << "frame " << q;
    EXPECT_EQ(refs.front(), 0) << "frame " << q;
    EXPECT_LE(refs.back(), 11) << "frame " << q;
    // Every frame of the start the closures name (0-9 up to frame 188) shares ground with it.
    if (q >= 187) {
      for (int r = 0; r <= 9; ++r) {
        EXPECT_TRUE(std::binary_search(refs.begin(), refs.end(), r)) << q << " " << r;
      }
    }
  }
}

// For ground-truth pairs the known homography lines the two images up: after warping r onto q
// they share part of the picture and it correlates strongly, through exposure and noise changes.
// A quarter of the smaller ground footprint can lie in the far part of q's view, where a square
// metre takes few pixels, so the shared share of the picture can be well below a quarter.
TEST(GroundTruth, PairsShareTheirContent) {
  const SyntheticSequence sequence(demoOptions(800, 11));
  const auto& pairs = sequence.groundTruth();
  ASSERT_GT(pairs.size(), 50u);
  const cv::Size size(sequence.camera().width, sequence.camera().height);
  const cv::Mat full(size, CV_8U, cv::Scalar(255));
  SeededRandom pick(1);
  for (int k = 0; k < 12; ++k) {
    const auto [q, r] = pairs[pick.intIn(0, static_cast<int>(pairs.size()) - 1)];
    ASSERT_GE(q - r, sequence.options().min_revisit_gap);
    const cv::Matx33d r_to_q = sequence.homography(r, q);
    cv::Mat warped, mask;
    cv::warpPerspective(sequence.render(r), warped, r_to_q, size);
    cv::warpPerspective(full, mask, r_to_q, size, cv::INTER_NEAREST);
    cv::erode(mask, mask, cv::Mat(), cv::Point(-1, -1), 2);
    const double shared = cv::countNonZero(mask) / static_cast<double>(mask.total());
    EXPECT_GT(shared, 0.1) << "pair " << q << " " << r;
    EXPECT_GT(maskedNcc(sequence.render(q), warped, mask), 0.75) << "pair " << q << " " << r;
  }
}

// Frames far apart in space see disjoint ground and unrelated pictures.
TEST(GroundTruth, DistantFramesShareNothing) {
  const SyntheticSequence sequence(demoOptions(800, 11));
  SeededRandom pick(2);
  int checked = 0;
  double ncc_sum = 0;
  while (checked < 20) {
    const int a = pick.intIn(0, sequence.size() - 1), b = pick.intIn(0, sequence.size() - 1);
    const Pose pa = sequence.pose(a), pb = sequence.pose(b);
    if (std::hypot(pa.x - pb.x, pa.y - pb.y) < 40) continue;
    EXPECT_EQ(footprintOverlap(sequence.footprint(a), sequence.footprint(b)), 0);
    const auto refs = sequence.revisitsOf(std::max(a, b));
    EXPECT_EQ(std::count(refs.begin(), refs.end(), std::min(a, b)), 0);
    const cv::Mat mask(sequence.render(a).size(), CV_8U, cv::Scalar(255));
    const double ncc = maskedNcc(sequence.render(a), sequence.render(b), mask);
    EXPECT_LT(std::abs(ncc), 0.45);
    ncc_sum += std::abs(ncc);
    ++checked;
  }
  EXPECT_LT(ncc_sum / checked, 0.2);
}

TEST(GroundTruth, RevisitsOfAgreesWithThePairList) {
  const SyntheticSequence sequence(demoOptions(600, 5));
  std::size_t total = 0;
  for (int q = 0; q < sequence.size(); ++q) {
    const auto refs = sequence.revisitsOf(q);
    total += refs.size();
    for (std::size_t k = 0; k < refs.size(); ++k) {
      EXPECT_GE(q - refs[k], sequence.options().min_revisit_gap);
      if (k > 0) {
        EXPECT_LT(refs[k - 1], refs[k]);
      }
    }
  }
  EXPECT_EQ(total, sequence.groundTruth().size());
}

// Poses of the scale profile's camera (6 m up, 60 degrees below the horizon, 60 degree field).
Pose groundPose(double x, double y, double heading_degrees) {
  Pose pose;
  pose.x = x;
  pose.y = y;
  pose.heading = heading_degrees * CV_PI / 180.0;
  pose.height = 6.0;
  pose.pitch = 60.0 * CV_PI / 180.0;
  return pose;
}

TEST(GroundTruth, RelateViewsMeasuresWhatTheRuleIsStatedIn) {
  const auto camera = CameraIntrinsics::fromHorizontalFov(160, 120, 60.0 * CV_PI / 180.0);
  const GroundTruthSettings settings;

  const ViewRelation same =
      relateViews(120, groundPose(5, 5, 30), 20, groundPose(5, 5, 30), camera);
  EXPECT_EQ(same.gap, 100);
  EXPECT_NEAR(same.iou, 1.0, 1e-6);
  EXPECT_NEAR(same.shared, 1.0, 1e-6);
  EXPECT_NEAR(same.heading, 0.0, 1e-12);
  EXPECT_TRUE(isRevisit(same, settings));
  // The same view, too soon after: neighbours in time are not loops.
  EXPECT_FALSE(
      isRevisit(relateViews(69, groundPose(5, 5, 30), 20, groundPose(5, 5, 30), camera), settings));

  // Headings wrap: 350 and 10 degrees are 20 apart.
  const ViewRelation wrapped =
      relateViews(100, groundPose(0, 0, 350), 0, groundPose(0, 0, 10), camera);
  EXPECT_NEAR(wrapped.heading * 180 / CV_PI, 20.0, 1e-9);
  EXPECT_TRUE(isRevisit(wrapped, settings) == (wrapped.shared >= settings.min_shared));
  // Turned 40 degrees on the spot: the views share ground, and the heading plays no part.
  const ViewRelation turned =
      relateViews(100, groundPose(0, 0, 40), 0, groundPose(0, 0, 0), camera);
  EXPECT_GT(turned.shared, settings.min_shared);
  EXPECT_TRUE(isRevisit(turned, settings));

  // Driving on along the street: the shared ground falls, and the shared fraction of the smaller
  // footprint is never below the IoU.
  double last_shared = 2;
  for (double ahead = 0; ahead <= 30; ahead += 2) {
    const ViewRelation moved =
        relateViews(100, groundPose(ahead, 0, 0), 0, groundPose(0, 0, 0), camera);
    EXPECT_GE(moved.shared + 1e-6, moved.iou);  // float clipping
    EXPECT_LE(moved.shared, last_shared + 1e-9);
    last_shared = moved.shared;
  }
  EXPECT_EQ(last_shared, 0.0);  // 30 m on, the two footprints are disjoint
}

// Common ground, any heading. Driving a street the other way sees the same ground rotated half
// a turn: a revisit, and a closure onto it is right.
TEST(GroundTruth, IsRevisitOnCommonGroundWhateverTheHeading) {
  const auto camera = CameraIntrinsics::fromHorizontalFov(160, 120, 60.0 * CV_PI / 180.0);
  const GroundTruthSettings settings;
  const Pose outward = groundPose(0, 0, 0);
  // The footprint of a camera 6 m up at 60 degrees runs from ~0.7 m to ~8 m ahead, so a camera
  // 8.7 m on looking back sees the same stretch of street.
  const ViewRelation back = relateViews(500, groundPose(8.7, 0, 180), 100, outward, camera);
  EXPECT_NEAR(back.heading * 180 / CV_PI, 180.0, 1e-9);
  EXPECT_GT(back.shared, 0.5);
  EXPECT_TRUE(isRevisit(back, settings));
  // The same views 49 frames apart: the recent past is not a loop.
  EXPECT_FALSE(
      isRevisit(relateViews(149, groundPose(8.7, 0, 180), 100, outward, camera), settings));
  // Side by side across a crossing, turned a quarter: still common ground.
  const ViewRelation crossing = relateViews(500, groundPose(4, -4, 90), 100, outward, camera);
  EXPECT_GE(crossing.shared, settings.min_shared);
  EXPECT_TRUE(isRevisit(crossing, settings));
  // Alike views: IoU >= 0.5 implies shared >= 0.5.
  const ViewRelation alike = relateViews(500, groundPose(1, 0.5, 10), 100, outward, camera);
  EXPECT_GE(alike.iou, 0.5);
  EXPECT_TRUE(isRevisit(alike, settings));
  // Looking away from each other, or a street apart: nothing in common, a false closure.
  EXPECT_FALSE(isRevisit(relateViews(500, groundPose(0, 0, 180), 100, outward, camera), settings));
  EXPECT_FALSE(isRevisit(relateViews(500, groundPose(0, 20, 0), 100, outward, camera), settings));
  // A sliver of common ground is not enough: the bound is on the smaller footprint's share.
  const ViewRelation sliver = relateViews(500, groundPose(7, 0, 0), 100, outward, camera);
  EXPECT_GT(sliver.shared, 0.0);
  EXPECT_LT(sliver.shared, settings.min_shared);
  EXPECT_FALSE(isRevisit(sliver, settings));
}

// The rule as a benchmark applies it to one closure (relateViews() then isRevisit()) is the rule
// the list was made with: a closure onto a listed frame is right, and onto any other frame wrong.
TEST(GroundTruth, IsRevisitAgreesWithTheList) {
  const SyntheticSequence sequence(demoOptions(400, 5));
  const GroundTruthSettings settings;
  std::vector<std::pair<int, int>> listed;
  for (int q = 0; q < sequence.size(); ++q) {
    for (int r = 0; r < q; ++r) {
      const ViewRelation v =
          relateViews(q, sequence.pose(q), r, sequence.pose(r), sequence.camera());
      if (isRevisit(v, settings)) listed.emplace_back(q, r);
    }
  }
  ASSERT_FALSE(listed.empty());
  EXPECT_EQ(listed, sequence.groundTruth());
}

}  // namespace
}  // namespace placedb::synthetic
