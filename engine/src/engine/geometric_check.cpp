#include "engine/geometric_check.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>

namespace placedb {
namespace {

// RANSAC's 8-point fundamental matrix needs 8 pairs.
constexpr int kMinimalPairs = 8;

}  // namespace

std::vector<std::uint8_t> encodeDescriptors(const cv::Mat& descriptors) {
  const int dim = descriptors.cols;
  std::vector<std::uint8_t> out;
  out.reserve(static_cast<std::size_t>(descriptors.rows) * (sizeof(float) + dim));
  for (int r = 0; r < descriptors.rows; ++r) {
    const float* row = descriptors.ptr<float>(r);
    float scale = 0.f;
    for (int c = 0; c < dim; ++c) scale = std::max(scale, std::abs(row[c]));
    std::uint8_t scale_bytes[sizeof(float)];
    std::memcpy(scale_bytes, &scale, sizeof(float));
    out.insert(out.end(), scale_bytes, scale_bytes + sizeof(float));
    for (int c = 0; c < dim; ++c) {
      const float v = scale > 0.f ? std::round(row[c] / scale * 127.f) : 0.f;
      out.push_back(static_cast<std::uint8_t>(static_cast<std::int8_t>(v)));
    }
  }
  return out;
}

cv::Mat decodeDescriptors(const std::vector<std::uint8_t>& bytes, int dim) {
  const std::size_t row_bytes = sizeof(float) + static_cast<std::size_t>(dim);
  if (dim <= 0 || bytes.size() % row_bytes != 0) return cv::Mat();
  const int rows = static_cast<int>(bytes.size() / row_bytes);
  cv::Mat out(rows, dim, CV_32F);
  for (int r = 0; r < rows; ++r) {
    const std::uint8_t* in = bytes.data() + static_cast<std::size_t>(r) * row_bytes;
    float scale = 0.f;
    std::memcpy(&scale, in, sizeof(float));
    float* row = out.ptr<float>(r);
    for (int c = 0; c < dim; ++c)
      row[c] = static_cast<float>(static_cast<std::int8_t>(in[sizeof(float) + c])) * scale / 127.f;
  }
  return out;
}

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
