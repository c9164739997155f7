#include "features/surf_extractor.h"

#include "features/image_conversion.h"
#include "features/integral_image.h"
#include "features/keypoint_ranking.h"
#include "features/surf_descriptor.h"
#include "features/surf_detector.h"

namespace placedb {

SurfExtractor::SurfExtractor(const FeatureOptions& options) : options_(options) {
  validateFeatureOptions(options_);
}

const std::string& SurfExtractor::name() const {
  static const std::string kName = "surf";
  return kName;
}

int SurfExtractor::dim() const { return kSurfDescriptorDim; }

Features SurfExtractor::extract(const cv::Mat& grey8) const {
  requireExtractableImage(grey8, name());
  const int threads = resolveThreadCount(options_.threads);
  const IntegralImage integral(grey8);
  SurfDetectorSettings detector;
  detector.hessian_threshold = options_.hessian_threshold;
  detector.octaves = options_.octaves;
  detector.intervals = options_.intervals;
  detector.edge_ratio = options_.edge_ratio;
  detector.threads = threads;
  const std::vector<cv::KeyPoint> blobs = detectSurfBlobs(integral, detector);

  // Rank before describing so that max_features also saves the descriptor work.
  const std::vector<int> kept = rankKeypoints(blobs, options_.max_features, options_.min_response);
  std::vector<cv::KeyPoint> keypoints;
  keypoints.reserve(kept.size());
  for (int index : kept) keypoints.push_back(blobs[index]);
  cv::Mat descriptors;
  describeSurfKeypoints(integral, keypoints, options_.upright, threads, descriptors);
  return makeFeatures(name(), type(), dim(), keypoints, descriptors, 0, 0.0f);
}

}  // namespace placedb
