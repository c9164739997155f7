#pragma once
// The one place where detector output becomes Features: strongest first, with max_features and
// min_response applied the same way for every extractor.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "features/features.h"

namespace placedb {

// Indices into `keypoints` of those kept: response >= min_response, sorted by response
// (descending), at most max_features of them (0 = no limit). Ties are broken by y, x, size, angle
// and then index, so the order never depends on the detector's internal order.
std::vector<int> rankKeypoints(const std::vector<cv::KeyPoint>& keypoints, int max_features,
                               float min_response);

// Features made of the ranked keypoints and their descriptor rows (descriptors has one row per
// keypoint, dim columns, CV_32F for kFloat32 or CV_8U for kBinary8U).
Features makeFeatures(const std::string& extractor, DescriptorType type, int dim,
                      const std::vector<cv::KeyPoint>& keypoints, const cv::Mat& descriptors,
                      int max_features, float min_response);

// Converts one OpenCV keypoint (angle -1 stays -1; other angles are wrapped into [0, 360)).
Keypoint toKeypoint(const cv::KeyPoint& keypoint);

}  // namespace placedb
