#include "features/keypoint_ranking.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "placedb/error.h"

namespace placedb {

std::vector<int> rankKeypoints(const std::vector<cv::KeyPoint>& keypoints, int max_features,
                               float min_response) {
  std::vector<int> order;
  order.reserve(keypoints.size());
  for (int i = 0; i < static_cast<int>(keypoints.size()); ++i) {
    if (keypoints[i].response >= min_response) order.push_back(i);
  }
  auto stronger = [&](int a, int b) {
    const cv::KeyPoint& ka = keypoints[a];
    const cv::KeyPoint& kb = keypoints[b];
    if (ka.response != kb.response) return ka.response > kb.response;
    if (ka.pt.y != kb.pt.y) return ka.pt.y < kb.pt.y;
    if (ka.pt.x != kb.pt.x) return ka.pt.x < kb.pt.x;
    if (ka.size != kb.size) return ka.size < kb.size;
    if (ka.angle != kb.angle) return ka.angle < kb.angle;
    return a < b;
  };
  const std::size_t keep =
      max_features > 0 ? std::min<std::size_t>(order.size(), max_features) : order.size();
  if (keep < order.size()) {
    std::partial_sort(order.begin(), order.begin() + keep, order.end(), stronger);
    order.resize(keep);
  } else {
    std::sort(order.begin(), order.end(), stronger);
  }
  return order;
}

Keypoint toKeypoint(const cv::KeyPoint& keypoint) {
  Keypoint out;
  out.x = keypoint.pt.x;
  out.y = keypoint.pt.y;
  out.size = keypoint.size;
  out.response = keypoint.response;
  out.octave = keypoint.octave;
  if (keypoint.angle < 0) {
    out.angle = -1;
  } else {
    float angle = std::fmod(keypoint.angle, 360.0f);
    out.angle = angle >= 360.0f ? 0.0f : angle;
  }
  return out;
}

Features makeFeatures(const std::string& extractor, DescriptorType type, int dim,
                      const std::vector<cv::KeyPoint>& keypoints, const cv::Mat& descriptors,
                      int max_features, float min_response) {
  const int expected_type = type == DescriptorType::kFloat32 ? CV_32F : CV_8U;
  if (!keypoints.empty() && (descriptors.rows != static_cast<int>(keypoints.size()) ||
                             descriptors.cols != dim || descriptors.type() != expected_type)) {
    throw Error(ErrorCode::kInternal,
                extractor + ": descriptor matrix does not match its keypoints (" +
                    std::to_string(descriptors.rows) + "x" + std::to_string(descriptors.cols) +
                    " for " + std::to_string(keypoints.size()) + " keypoints of dim " +
                    std::to_string(dim) + ")");
  }
  Features features;
  features.extractor = extractor;
  features.type = type;
  features.dim = dim;
  const std::vector<int> order = rankKeypoints(keypoints, max_features, min_response);
  features.keypoints.reserve(order.size());
  features.descriptors.create(static_cast<int>(order.size()), dim, expected_type);
  for (std::size_t row = 0; row < order.size(); ++row) {
    features.keypoints.push_back(toKeypoint(keypoints[order[row]]));
    descriptors.row(order[row]).copyTo(features.descriptors.row(static_cast<int>(row)));
  }
  return features;
}

}  // namespace placedb
