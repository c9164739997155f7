#include "features/opencv_extractors.h"

#include <mutex>

#include "features/image_conversion.h"
#include "features/keypoint_ranking.h"

namespace placedb {

OpenCvExtractor::OpenCvExtractor(const FeatureOptions& options, std::string name, int dim,
                                 DescriptorType type, cv::Ptr<cv::Feature2D> detector)
    : options_(options),
      name_(std::move(name)),
      dim_(dim),
      type_(type),
      detector_(std::move(detector)) {}

Features OpenCvExtractor::extract(const cv::Mat& grey8) const {
  requireExtractableImage(grey8, name_);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  detector_->detectAndCompute(grey8, cv::noArray(), keypoints, descriptors);
  if (keypoints.empty())
    descriptors = cv::Mat(0, dim_, type_ == DescriptorType::kFloat32 ? CV_32F : CV_8U);
  Features features = makeFeatures(name_, type_, dim_, keypoints, descriptors,
                                   options_.max_features, options_.min_response);
  features.image_size = grey8.size();
  return features;
}

SiftExtractor::SiftExtractor(const FeatureOptions& options)
    : OpenCvExtractor(options, "sift", 128, DescriptorType::kFloat32,
                      cv::SIFT::create(options.max_features, 3, options.sift_contrast_threshold)) {}

KazeExtractor::KazeExtractor(const FeatureOptions& options)
    : OpenCvExtractor(
          options, "kaze", 64, DescriptorType::kFloat32,
          cv::KAZE::create(false, options.upright, static_cast<float>(options.kaze_threshold),
                           options.octaves)) {}

OrbExtractor::OrbExtractor(const FeatureOptions& options)
    : OpenCvExtractor(
          options, "orb", 32, DescriptorType::kBinary8U,
          cv::ORB::create(options.max_features > 0 ? options.max_features : 1000, 1.2f, 8, 31, 0, 2,
                          cv::ORB::HARRIS_SCORE, 31, options.orb_fast_threshold)) {}

}  // namespace placedb
