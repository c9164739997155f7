#pragma once
// OpenCV's SIFT (128-d), KAZE (64-d) and ORB (32-byte binary) behind the FeatureExtractor
// interface. Their parallelism follows cv::setNumThreads(), not FeatureOptions::threads.
#include <string>

#include <opencv2/features2d.hpp>

#include "features/feature_extractor.h"

namespace placedb {

// Shared body: detectAndCompute, then the common ranking (max_features, min_response).
class OpenCvExtractor : public FeatureExtractor {
 public:
  Features extract(const cv::Mat& grey8) const override;
  const std::string& name() const override { return name_; }
  int dim() const override { return dim_; }
  DescriptorType type() const override { return type_; }

 protected:
  OpenCvExtractor(const FeatureOptions& options, std::string name, int dim, DescriptorType type,
                  cv::Ptr<cv::Feature2D> detector);

 private:
  FeatureOptions options_;
  std::string name_;
  int dim_;
  DescriptorType type_;
  cv::Ptr<cv::Feature2D> detector_;
};

// SIFT: nfeatures = max_features, contrastThreshold = sift_contrast_threshold, other settings
// OpenCV's defaults. Responses are SIFT's DoG contrast.
class SiftExtractor : public OpenCvExtractor {
 public:
  explicit SiftExtractor(const FeatureOptions& options);
};

// KAZE: 64-d (not extended), upright and octaves from the options, threshold = kaze_threshold,
// 4 sublevels, PM_G2 diffusivity (OpenCV's defaults).
class KazeExtractor : public OpenCvExtractor {
 public:
  explicit KazeExtractor(const FeatureOptions& options);
};

// ORB: nfeatures = max_features (1000 when 0), fastThreshold = orb_fast_threshold. Binary:
// only for benchmarks until the vocabulary supports Hamming distance.
class OrbExtractor : public OpenCvExtractor {
 public:
  explicit OrbExtractor(const FeatureOptions& options);
};

}  // namespace placedb
