// The essential-matrix pose of relative_pose.h on synthetic views: a known rotation and
// translation, points projected through known intrinsics, and what comes back.
#include "geometry/relative_pose.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <opencv2/calib3d.hpp>

namespace placedb {
namespace {

constexpr double kPi = 3.14159265358979323846;

double degrees(double radians) { return radians * 180.0 / kPi; }

// The angle of the rotation between two rotation matrices, degrees.
double rotationError(const cv::Matx33d& a, const cv::Matx33d& b) {
  const cv::Matx33d d = a.t() * b;
  const double c = std::clamp((d(0, 0) + d(1, 1) + d(2, 2) - 1) / 2, -1.0, 1.0);
  return degrees(std::acos(c));
}

double angleBetween(const cv::Vec3d& a, const cv::Vec3d& b) {
  const double c = std::clamp(a.dot(b) / (cv::norm(a) * cv::norm(b)), -1.0, 1.0);
  return degrees(std::acos(c));
}

struct Scene {
  std::vector<cv::Point2f> a, b;  // pixels of camera a and camera b
};

// Points in front of camera a, seen by a and by b, where X_b = R X_a + t. Pixel noise of
// `noise_px` (Gaussian) and `outliers` pairs replaced by random pixels.
Scene project(const cv::Matx33d& r, const cv::Vec3d& t, const CameraIntrinsics& ka,
              const CameraIntrinsics& kb, int points, double noise_px, int outliers,
              unsigned seed = 7) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> lateral(-4, 4), depth(4, 15), pixel(0, 240);
  std::normal_distribution<double> noise(0, noise_px);
  Scene s;
  while (static_cast<int>(s.a.size()) < points) {
    const cv::Vec3d xa(lateral(rng), lateral(rng) * 0.7, depth(rng));
    const cv::Vec3d xb = r * xa + t;
    if (xb[2] < 1) continue;
    s.a.emplace_back(ka.fx * xa[0] / xa[2] + ka.cx + noise(rng),
                     ka.fy * xa[1] / xa[2] + ka.cy + noise(rng));
    s.b.emplace_back(kb.fx * xb[0] / xb[2] + kb.cx + noise(rng),
                     kb.fy * xb[1] / xb[2] + kb.cy + noise(rng));
  }
  for (int i = 0; i < outliers && i < points; ++i)
    s.b[static_cast<std::size_t>(i * 3 % points)] = cv::Point2f(pixel(rng), pixel(rng) * 0.8f);
  return s;
}

cv::Matx33d rotation(double rx, double ry, double rz) {  // degrees, as a rotation vector
  cv::Matx33d r;
  cv::Rodrigues(cv::Vec3d(rx, ry, rz) * (kPi / 180.0), r);
  return r;
}

const CameraIntrinsics kCamera{190, 190, 120, 96};  // lip6_outdoor's size, 64 degrees across

TEST(RelativePose, RecoversAKnownMotionWithinADegree) {
  const cv::Matx33d r = rotation(2, -12, 3);
  const cv::Vec3d t(0.4, 0.05, -1.0);
  // Exact projections: the essential matrix is the true one.
  const Scene exact = project(r, t, kCamera, kCamera, 30, 0.0, 0);
  const auto pose = relativePose(exact.a, kCamera, exact.b, kCamera);
  ASSERT_TRUE(pose);
  const cv::Matx33d got = rotationOf({pose->qw, pose->qx, pose->qy, pose->qz});
  EXPECT_LT(rotationError(got, r), 0.01);
  const cv::Vec3d direction(pose->tx, pose->ty, pose->tz);
  EXPECT_NEAR(cv::norm(direction), 1.0, 1e-9);
  EXPECT_LT(angleBetween(direction, t), 0.01);
  EXPECT_EQ(pose->inliers, 30);
  EXPECT_GE(pose->qw, 0.0);

  // Keypoint noise (0.5 px at f = 190, 0.15 degrees) and 10 % wrong pairs: the rotation stays
  // within a degree; the direction of a short baseline is less certain (README: figures).
  const Scene noisy = project(r, t, kCamera, kCamera, 150, 0.5, 15);
  const auto rough = relativePose(noisy.a, kCamera, noisy.b, kCamera);
  ASSERT_TRUE(rough);
  EXPECT_LT(rotationError(rotationOf({rough->qw, rough->qx, rough->qy, rough->qz}), r), 1.0);
  EXPECT_LT(angleBetween({rough->tx, rough->ty, rough->tz}, t), 5.0);
  EXPECT_LE(rough->inliers, 150 - 10);
}

TEST(RelativePose, TwoCamerasOfDifferentIntrinsics) {
  const CameraIntrinsics other{420, 410, 256, 190};
  const cv::Matx33d r = rotation(-4, 25, 1);
  const cv::Vec3d t(-0.5, 0.1, 0.9);
  const Scene s = project(r, t, kCamera, other, 40, 0.0, 0);
  const auto pose = relativePose(s.a, kCamera, s.b, other);
  ASSERT_TRUE(pose);
  EXPECT_LT(rotationError(rotationOf({pose->qw, pose->qx, pose->qy, pose->qz}), r), 0.01);
  EXPECT_LT(angleBetween({pose->tx, pose->ty, pose->tz}, t), 0.01);
  // The wrong camera for b bends the answer: each side's intrinsics are used.
  const auto wrong = relativePose(s.a, kCamera, s.b, kCamera);
  if (wrong) {
    EXPECT_GT(rotationError(rotationOf({wrong->qw, wrong->qx, wrong->qy, wrong->qz}), r), 1.0);
  }
}

TEST(RelativePose, DeterministicWhateverOpenCvsGlobalGenerator) {
  const Scene s = project(rotation(1, 8, -2), {0.6, 0, 0.4}, kCamera, kCamera, 40, 1.0, 8);
  const auto first = relativePose(s.a, kCamera, s.b, kCamera);
  cv::theRNG().state = 12345;  // a resumed process starts with other global state
  for (int i = 0; i < 17; ++i) cv::theRNG().next();
  const auto second = relativePose(s.a, kCamera, s.b, kCamera);
  ASSERT_TRUE(first && second);
  EXPECT_EQ(first->qw, second->qw);
  EXPECT_EQ(first->qx, second->qx);
  EXPECT_EQ(first->tz, second->tz);
  EXPECT_EQ(first->inliers, second->inliers);
}

TEST(RelativePose, NoneWithoutIntrinsicsOrPairs) {
  const Scene s = project(rotation(0, 10, 0), {1, 0, 0}, kCamera, kCamera, 30, 0, 0);
  EXPECT_FALSE(relativePose(s.a, CameraIntrinsics{}, s.b, kCamera));
  EXPECT_FALSE(relativePose(s.a, kCamera, s.b, CameraIntrinsics{}));
  const std::vector<cv::Point2f> four(s.a.begin(), s.a.begin() + 4),
      four_b(s.b.begin(), s.b.begin() + 4);
  EXPECT_FALSE(relativePose(four, kCamera, four_b, kCamera));
}

TEST(RelativePose, QuaternionRoundTrip) {
  for (const cv::Vec3d& v : {cv::Vec3d(0, 0, 0), cv::Vec3d(179, 0, 0), cv::Vec3d(0, -170, 5),
                             cv::Vec3d(10, 20, 175), cv::Vec3d(-30, 40, -50)}) {
    const cv::Matx33d r = rotation(v[0], v[1], v[2]);
    const auto q = quaternionOf(r);
    EXPECT_NEAR(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0, 1e-12);
    EXPECT_GE(q[0], 0.0);
    EXPECT_LT(rotationError(rotationOf(q), r), 1e-5) << v;
  }
}

}  // namespace
}  // namespace placedb
