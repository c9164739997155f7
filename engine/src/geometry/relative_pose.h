#pragma once
// The relative pose of two views of one rigid scene from their point pairs, when both cameras'
// intrinsics are known: an essential matrix fitted on normalised coordinates by OpenCV's USAC
// (5-point samples, local optimisation and a final least-squares fit on the inliers), then the
// one of its four decompositions that puts the most points in front of both cameras.
// A single camera measures no scale, so the translation is a direction only.
//
// The geometric check has already accepted the pairs (its 7-point fundamental matrix and rule
// decide, geometric_check.h); this only measures, on the pairs that agreed with that matrix.
#include <array>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "placedb/options.h"
#include "placedb/storage/records.h"

namespace placedb {

struct CameraIntrinsics {  // pinhole, pixels
  double fx = 0, fy = 0, cx = 0, cy = 0;
  bool known() const { return fx > 0 && fy > 0; }
};
CameraIntrinsics intrinsicsOf(const Options& options);

struct RelativePoseSettings {
  double max_error_px = Options().geometry_max_error_px;  // RANSAC: epipolar distance, pixels
  double confidence = 0.999;
  int iterations = 1000;  // RANSAC samples at most
  int min_inliers = 5;    // fewer pairs in front of both cameras: no pose
};

// The pose of camera a in camera b: a point X in a's coordinates is R X + s t in b's (s > 0
// unknown), for pairs a[i] (pixels of a) <-> b[i] (pixels of b). None when either camera is
// unknown, with fewer than 5 pairs, or when no decomposition has min_inliers pairs in front.
// Deterministic: USAC seeds its own generator on every call (cv::theRNG() plays no part).
std::optional<storage::ClosurePose> relativePose(const std::vector<cv::Point2f>& a,
                                                 const CameraIntrinsics& camera_a,
                                                 const std::vector<cv::Point2f>& b,
                                                 const CameraIntrinsics& camera_b,
                                                 const RelativePoseSettings& settings = {});

// Rotation matrix <-> unit quaternion (w, x, y, z; w >= 0).
std::array<double, 4> quaternionOf(const cv::Matx33d& rotation);
cv::Matx33d rotationOf(const std::array<double, 4>& wxyz);

}  // namespace placedb
