#include "geometry/scene_extent.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "geometry/geometric_check.h"

namespace placedb {
namespace {

constexpr int kMaxPlanes = 3;
// A one-sided test at the customary 5 % level: the normal quantile.
constexpr double kOneSidedFivePercent = 1.645;

// The mean and standard deviation of the log of hullShare(k) for k = 3..64, 20,000 draws each
// (bench/quality/hull_shares.py).
constexpr std::array<double, 62> kLogHullMean = {
    -3.1026, -2.0990, -1.6456, -1.3742, -1.1856, -1.0479, -0.9467, -0.8640, -0.7944,
    -0.7395, -0.6925, -0.6462, -0.6095, -0.5765, -0.5486, -0.5228, -0.5011, -0.4782,
    -0.4600, -0.4437, -0.4272, -0.4130, -0.3992, -0.3852, -0.3742, -0.3620, -0.3530,
    -0.3430, -0.3339, -0.3256, -0.3163, -0.3088, -0.3014, -0.2959, -0.2892, -0.2819,
    -0.2772, -0.2708, -0.2660, -0.2596, -0.2534, -0.2499, -0.2457, -0.2414, -0.2373,
    -0.2324, -0.2289, -0.2254, -0.2217, -0.2179, -0.2136, -0.2110, -0.2084, -0.2055,
    -0.2017, -0.1992, -0.1971, -0.1939, -0.1903, -0.1889, -0.1866, -0.1843};
constexpr std::array<double, 62> kLogHullDeviation = {
    1.2573, 0.7292, 0.5481, 0.4443, 0.3766, 0.3262, 0.2928, 0.2677, 0.2460, 0.2254, 0.2106,
    0.1961, 0.1842, 0.1744, 0.1633, 0.1563, 0.1495, 0.1425, 0.1370, 0.1328, 0.1268, 0.1234,
    0.1189, 0.1138, 0.1104, 0.1063, 0.1037, 0.1003, 0.0981, 0.0952, 0.0920, 0.0902, 0.0876,
    0.0850, 0.0843, 0.0816, 0.0804, 0.0781, 0.0765, 0.0744, 0.0734, 0.0721, 0.0707, 0.0695,
    0.0685, 0.0669, 0.0659, 0.0642, 0.0635, 0.0623, 0.0615, 0.0601, 0.0593, 0.0581, 0.0578,
    0.0559, 0.0560, 0.0547, 0.0536, 0.0532, 0.0528, 0.0519};

std::size_t row(int k) { return static_cast<std::size_t>(std::min(k, 64) - 3); }

std::vector<int> allOf(std::size_t n) {
  std::vector<int> all(n);
  for (std::size_t i = 0; i < n; ++i) all[i] = static_cast<int>(i);
  return all;
}

// The agreeing pairs a region is measured on: those on planes, or all when none is.
std::vector<int> regionPairs(const GeometricResult& g, double tolerance) {
  std::vector<int> planar = planarPairs(g.agreeing_query, g.agreeing_candidate, tolerance);
  return planar.empty() ? allOf(g.agreeing_query.size()) : planar;
}

}  // namespace

std::vector<int> planarPairs(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b,
                             double tolerance) {
  std::vector<int> left = allOf(std::min(a.size(), b.size()));
  std::vector<int> planar;
  for (int plane = 0; plane < kMaxPlanes && static_cast<int>(left.size()) >= kMinPlanePairs;
       ++plane) {
    std::vector<cv::Point2f> from, to;
    for (int i : left) {
      from.push_back(a[static_cast<std::size_t>(i)]);
      to.push_back(b[static_cast<std::size_t>(i)]);
    }
    cv::Mat mask;
    const cv::Mat h = cv::findHomography(from, to, cv::RANSAC, tolerance, mask, 2000, 0.999);
    if (h.empty()) break;
    // The plane's pairs are those within tolerance of the refined model (RANSAC's own mask is
    // of the sample's model, which a pair near the tolerance can miss).
    std::vector<cv::Point2f> mapped;
    cv::perspectiveTransform(from, mapped, h);
    std::vector<int> on, rest;
    for (std::size_t j = 0; j < left.size(); ++j)
      (cv::norm(mapped[j] - to[j]) <= tolerance ? on : rest).push_back(left[j]);
    if (static_cast<int>(on.size()) < kMinPlanePairs) break;
    planar.insert(planar.end(), on.begin(), on.end());
    left = std::move(rest);
  }
  std::sort(planar.begin(), planar.end());
  return planar;
}

double hullArea(const std::vector<cv::Point2f>& points, const std::vector<int>& indices) {
  if (indices.size() < 3) return 0;
  std::vector<cv::Point2f> chosen;
  chosen.reserve(indices.size());
  for (int i : indices) chosen.push_back(points[static_cast<std::size_t>(i)]);
  std::vector<cv::Point2f> hull;
  cv::convexHull(chosen, hull);
  return cv::contourArea(hull);
}

SceneShare sceneShare(const GeometricResult& place, const GeometricResult* own_view,
                      double tolerance) {
  SceneShare s;
  const double plane_tolerance = 2 * tolerance;
  const std::vector<int> place_pairs = regionPairs(place, plane_tolerance);
  s.place_pairs = static_cast<int>(place_pairs.size());
  s.place_area = hullArea(place.agreeing_query, place_pairs);
  if (!own_view || static_cast<int>(own_view->agreeing_query.size()) < kMinPlanePairs) return s;
  const std::vector<int> scene = regionPairs(*own_view, plane_tolerance);
  s.scene_pairs = static_cast<int>(scene.size());
  s.scene_area = hullArea(own_view->agreeing_query, scene);
  if (s.scene_area <= 0) return s;
  s.measured = s.place_pairs >= 3 && s.scene_pairs >= 3;
  if (!s.measured) return s;
  // log(hull_p / hull_s) = log(share) + log X(k_p) - log X(k_s), X(k) the hull share of k
  // uniform points; its noise, taken as normal, has the tables' means and deviations.
  const std::size_t p = row(s.place_pairs), q = row(s.scene_pairs);
  const double z = kOneSidedFivePercent;
  s.share = std::exp(std::log(s.place_area / s.scene_area) - (kLogHullMean[p] - kLogHullMean[q]) +
                     z * std::hypot(kLogHullDeviation[p], kLogHullDeviation[q]));
  return s;
}

}  // namespace placedb
