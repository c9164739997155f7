#pragma once
// Epipolar verification of a loop-closure hypothesis. The query image's features are matched to
// the candidate location's keypoints by their own descriptors (kept with the location, see
// encodeDescriptors; only a map made before they were kept falls back to the descriptors of the
// words its keypoints were quantised to), with a ratio test, and a RANSAC fundamental matrix
// counts how many matches one rigid scene explains. Look-alike
// places share words too, but their matches scatter instead of agreeing on one geometry.
//
// Words alone pair too few keypoints: a true revisit of lip6_outdoor shares ~20 words out of 400
// features, mostly not unique ones, while nearest-descriptor matching pairs several times more.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "placedb/options.h"

namespace placedb {

// Defaults are Options' (geometry_min_inliers, geometry_max_error_px, geometry_match_ratio).
struct GeometricCheckSettings {
  int min_inliers = Options().geometry_min_inliers;       // matches that must agree; 0 = no check
  double max_error_px = Options().geometry_max_error_px;  // RANSAC distance from the epipolar line
  double match_ratio = Options().geometry_match_ratio;    // nearest / second-nearest distance
};

struct GeometricResult {
  int matches = 0;  // descriptor matches passing the ratio test
  int inliers = 0;  // of them, consistent with the best fundamental matrix
};

struct GeometricView {  // keypoints and one descriptor row per keypoint (CV_32F)
  std::vector<cv::Point2f> points;
  cv::Mat descriptors;
};

// A location's own keypoint descriptors, kept for the check at one byte per value: each row
// stores its largest magnitude as a float, then every value as a signed byte of that scale.
// The check always uses the decoded values, so a resumed run sees exactly what a straight one did.
std::vector<std::uint8_t> encodeDescriptors(const cv::Mat& descriptors);     // CV_32F rows
cv::Mat decodeDescriptors(const std::vector<std::uint8_t>& bytes, int dim);  // empty if malformed

// Deterministic (OpenCV's RANSAC seeds its generator per call), so a resumed run repeats it.
GeometricResult checkGeometry(const GeometricView& query, const GeometricView& candidate,
                              const GeometricCheckSettings& settings);

}  // namespace placedb
