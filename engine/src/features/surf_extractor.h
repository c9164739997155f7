#pragma once
// Our SURF-64 behind the FeatureExtractor interface.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "features/feature_extractor.h"

namespace placedb {

class SurfExtractor : public FeatureExtractor {
 public:
  // Options are validated here (Error kInvalidArgument on bad values).
  explicit SurfExtractor(const FeatureOptions& options);

  Features extract(const cv::Mat& grey8) const override;
  const std::string& name() const override;
  int dim() const override;
  DescriptorType type() const override { return DescriptorType::kFloat32; }

 private:
  // Detected and ranked keypoints of one image, in its own pixels; describe() adds their
  // descriptors, so that a search whose keypoints are dropped costs no description.
  struct Detection;
  Detection detect(const cv::Mat& grey8, int max_features, int threads) const;
  void describe(Detection& detection, int threads, cv::Mat& descriptors) const;

  FeatureOptions options_;
};

}  // namespace placedb
