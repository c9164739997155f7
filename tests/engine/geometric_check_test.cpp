// The geometric check must pass one rigid scene seen from two poses and refuse the same words
// scattered at unrelated places.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "engine/geometric_check.h"

namespace placedb {
namespace {

constexpr int kPoints = 60;
constexpr int kDim = 64;

cv::Mat randomUnitDescriptors(int rows, std::mt19937& rng) {
  std::normal_distribution<float> normal(0.f, 1.f);
  cv::Mat d(rows, kDim, CV_32F);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < kDim; ++c) d.at<float>(r, c) = normal(rng);
    cv::normalize(d.row(r), d.row(r));
  }
  return d;
}

// Pinhole camera (f = 200 px, 240x192 image) at x = tx looking down +z; the scene is 3D points
// 4..12 m ahead. A sideways step gives a real epipolar geometry.
std::vector<cv::Point2f> project(const std::vector<cv::Point3f>& scene, float tx) {
  std::vector<cv::Point2f> out;
  for (const auto& p : scene)
    out.emplace_back(120.f + 200.f * (p.x - tx) / p.z, 96.f + 200.f * p.y / p.z);
  return out;
}

struct TwoViews {
  GeometricView query, candidate;
};

TwoViews rigidScene(std::mt19937& rng) {
  std::uniform_real_distribution<float> x(-2.f, 2.f), y(-1.5f, 1.5f), z(4.f, 12.f);
  std::vector<cv::Point3f> scene;
  for (int i = 0; i < kPoints; ++i) scene.emplace_back(x(rng), y(rng), z(rng));
  TwoViews v;
  v.query.descriptors = randomUnitDescriptors(kPoints, rng);
  v.candidate.descriptors = v.query.descriptors.clone();
  v.query.points = project(scene, 0.f);
  v.candidate.points = project(scene, 0.6f);
  return v;
}

TEST(GeometricCheck, OneRigidSceneFromTwoPosesPasses) {
  std::mt19937 rng(7);
  TwoViews v = rigidScene(rng);
  GeometricCheckSettings settings;
  settings.min_inliers = 13;
  const GeometricResult r = checkGeometry(v.query, v.candidate, settings);
  EXPECT_EQ(r.matches, kPoints);
  EXPECT_GE(r.inliers, kPoints - 2);  // exact projections: all but RANSAC's rounding agree
}

TEST(GeometricCheck, SameWordsAtUnrelatedPlacesFail) {
  std::mt19937 rng(11);
  TwoViews v = rigidScene(rng);
  // Same descriptors, but every keypoint of the candidate lands somewhere random.
  std::uniform_real_distribution<float> u(0.f, 240.f), w(0.f, 192.f);
  for (auto& p : v.candidate.points) p = cv::Point2f(u(rng), w(rng));
  const GeometricResult r = checkGeometry(v.query, v.candidate, GeometricCheckSettings());
  EXPECT_EQ(r.matches, kPoints);
  EXPECT_LT(r.inliers, 20);  // chance agreement (13 here), far below the rigid scene's ~60
}

TEST(GeometricCheck, AmbiguousDescriptorsGiveNoMatches) {
  std::mt19937 rng(3);
  TwoViews v = rigidScene(rng);
  // Each candidate descriptor twice: nearest and second nearest tie, the ratio test refuses all.
  cv::vconcat(v.candidate.descriptors, v.candidate.descriptors, v.candidate.descriptors);
  auto points = v.candidate.points;
  v.candidate.points.insert(v.candidate.points.end(), points.begin(), points.end());
  const GeometricResult r = checkGeometry(v.query, v.candidate, GeometricCheckSettings());
  EXPECT_EQ(r.matches, 0);
  EXPECT_EQ(r.inliers, 0);
}

TEST(GeometricCheck, IsDeterministic) {
  std::mt19937 rng(5);
  TwoViews v = rigidScene(rng);
  std::uniform_real_distribution<float> u(0.f, 240.f), w(0.f, 192.f);
  for (int i = 0; i < kPoints / 2; ++i) v.candidate.points[i] = cv::Point2f(u(rng), w(rng));
  const GeometricResult a = checkGeometry(v.query, v.candidate, GeometricCheckSettings());
  const GeometricResult b = checkGeometry(v.query, v.candidate, GeometricCheckSettings());
  EXPECT_EQ(a.inliers, b.inliers);  // a resumed run must repeat every decision
  EXPECT_GE(a.inliers, kPoints / 2 - 2);
}

}  // namespace
}  // namespace placedb
