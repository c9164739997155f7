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
    -3.1002, -2.0950, -1.6442, -1.3718, -1.1860, -1.0496, -0.9452, -0.8623, -0.7944,
    -0.7382, -0.6896, -0.6465, -0.6080, -0.5800, -0.5508, -0.5240, -0.4996, -0.4792,
    -0.4605, -0.4417, -0.4262, -0.4126, -0.3980, -0.3861, -0.3735, -0.3630, -0.3527,
    -0.3426, -0.3341, -0.3254, -0.3165, -0.3093, -0.3022, -0.2957, -0.2884, -0.2839,
    -0.2756, -0.2712, -0.2652, -0.2600, -0.2556, -0.2495, -0.2460, -0.2413, -0.2366,
    -0.2323, -0.2289, -0.2255, -0.2212, -0.2181, -0.2153, -0.2113, -0.2075, -0.2049,
    -0.2024, -0.1991, -0.1964, -0.1941, -0.1913, -0.1886, -0.1865, -0.1844};
constexpr std::array<double, 62> kLogHullDeviation = {
    1.2459, 0.7275, 0.5484, 0.4434, 0.3742, 0.3281, 0.2939, 0.2654, 0.2428, 0.2254, 0.2096,
    0.1959, 0.1847, 0.1737, 0.1659, 0.1573, 0.1495, 0.1430, 0.1380, 0.1316, 0.1267, 0.1230,
    0.1172, 0.1141, 0.1112, 0.1075, 0.1033, 0.1002, 0.0977, 0.0958, 0.0918, 0.0904, 0.0884,
    0.0855, 0.0842, 0.0822, 0.0791, 0.0789, 0.0765, 0.0745, 0.0736, 0.0714, 0.0711, 0.0690,
    0.0679, 0.0665, 0.0655, 0.0647, 0.0629, 0.0623, 0.0609, 0.0602, 0.0593, 0.0582, 0.0580,
    0.0559, 0.0555, 0.0551, 0.0544, 0.0530, 0.0529, 0.0525};

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
