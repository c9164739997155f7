#include "engine/geometric_check.h"

#include <algorithm>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>

namespace placedb {
namespace {

// RANSAC's 8-point fundamental matrix needs 8 pairs.
constexpr int kMinimalPairs = 8;

}  // namespace

GeometricResult checkGeometry(const GeometricView& query, const GeometricView& candidate,
                              const GeometricCheckSettings& settings) {
  GeometricResult result;
  if (query.descriptors.rows < 2 || candidate.descriptors.rows < 2) return result;
  cv::BFMatcher matcher(cv::NORM_L2);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(query.descriptors, candidate.descriptors, knn, 2);
  // Ratio test, then one match per candidate keypoint (the closest) so that a repeated
  // texture cannot pile its matches onto one point.
  std::vector<cv::DMatch> kept;
  for (const auto& m : knn)
    if (m.size() == 2 && m[0].distance < settings.match_ratio * m[1].distance) kept.push_back(m[0]);
  std::sort(kept.begin(), kept.end(), [](const cv::DMatch& a, const cv::DMatch& b) {
    return a.trainIdx != b.trainIdx ? a.trainIdx < b.trainIdx : a.distance < b.distance;
  });
  std::vector<cv::Point2f> a, b;
  for (std::size_t k = 0; k < kept.size(); ++k) {
    if (k > 0 && kept[k].trainIdx == kept[k - 1].trainIdx) continue;
    a.push_back(query.points[static_cast<std::size_t>(kept[k].queryIdx)]);
    b.push_back(candidate.points[static_cast<std::size_t>(kept[k].trainIdx)]);
  }
  result.matches = static_cast<int>(a.size());
  if (result.matches < kMinimalPairs) return result;
  std::vector<unsigned char> mask;
  cv::Mat f = cv::findFundamentalMat(a, b, cv::FM_RANSAC, settings.max_error_px, 0.99, mask);
  if (f.empty()) return result;
  result.inliers = static_cast<int>(std::count(mask.begin(), mask.end(), 1));
  return result;
}

}  // namespace placedb
