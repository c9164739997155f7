#include "features/surf_extractor.h"

#include <algorithm>

#include <opencv2/imgproc.hpp>

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

struct SurfExtractor::Detection {
  IntegralImage integral;
  std::vector<cv::KeyPoint> keypoints;
};

SurfExtractor::Detection SurfExtractor::detect(const cv::Mat& grey8, int max_features,
                                               int threads) const {
  Detection d{IntegralImage(grey8), {}};
  SurfDetectorSettings detector;
  detector.hessian_threshold = options_.hessian_threshold;
  detector.octaves = options_.octaves;
  detector.intervals = options_.intervals;
  detector.edge_ratio = options_.edge_ratio;
  detector.threads = threads;
  const std::vector<cv::KeyPoint> blobs = detectSurfBlobs(d.integral, detector);

  // Rank before describing so that max_features also saves the descriptor work.
  const std::vector<int> kept = rankKeypoints(blobs, max_features, options_.min_response);
  d.keypoints.reserve(kept.size());
  for (int index : kept) d.keypoints.push_back(blobs[index]);
  return d;
}

void SurfExtractor::describe(Detection& detection, int threads, cv::Mat& descriptors) const {
  describeSurfKeypoints(detection.integral, detection.keypoints, options_.upright, threads,
                        descriptors);
}

Features SurfExtractor::extract(const cv::Mat& grey8) const {
  requireExtractableImage(grey8, name());
  const int threads = resolveThreadCount(options_.threads);
  Detection chosen = detect(grey8, options_.max_features, threads);
  // Too few blobs at the detector's finest scale: look again on the image doubled (Lowe's first
  // octave), where blobs of one or two pixels become detectable. An image with at most
  // feature_retry x the target is searched again, and the finer features, at most the target of
  // them, replace its own when they number at least 1 / feature_retry times as many. An image
  // that reached max_features is not starved, whatever the target. Keypoints come back in this
  // image's own pixels, so the check and a pose see the image the caller gave.
  bool doubled = false;
  const int target = options_.feature_target;
  const double retry = options_.feature_retry;
  const double count = static_cast<double>(chosen.keypoints.size());
  const bool capped = options_.max_features > 0 && count >= options_.max_features;
  if (target > 0 && retry > 0 && count <= retry * target && !capped) {
    cv::Mat twice;
    cv::resize(grey8, twice, cv::Size(), 2.0, 2.0, cv::INTER_LINEAR);
    const int cap = options_.max_features > 0 ? std::min(options_.max_features, target) : target;
    Detection finer = detect(twice, cap, threads);
    if (static_cast<double>(finer.keypoints.size()) * retry >= count) {
      chosen = std::move(finer);
      doubled = true;
    }
  }
  cv::Mat descriptors;
  describe(chosen, threads, descriptors);
  std::vector<cv::KeyPoint> keypoints = std::move(chosen.keypoints);
  if (doubled) {
    for (cv::KeyPoint& k : keypoints) {
      k.pt *= 0.5f;
      k.size *= 0.5f;
    }
  }
  Features features = makeFeatures(name(), type(), dim(), keypoints, descriptors, 0, 0.0f);
  features.image_size = grey8.size();
  return features;
}

}  // namespace placedb
