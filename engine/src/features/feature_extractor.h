#pragma once
// One interface for every feature extractor (our SURF, OpenCV's SIFT, KAZE and ORB), and the
// factory that builds the one a FeatureOptions names.
#include <memory>
#include <string>

#include <opencv2/core.hpp>

#include "features/feature_options.h"
#include "features/features.h"

namespace placedb {

class FeatureExtractor {
 public:
  virtual ~FeatureExtractor() = default;

  // Detects and describes `grey8` (CV_8UC1, at least kMinImageSide pixels each side; convert
  // other images with toGrey8()). Keypoints come strongest first with the options' max_features
  // and min_response applied. The same image and settings always give the same bits.
  // Throws Error(kInvalidArgument) for an empty, tiny or non-8-bit-grey image.
  virtual Features extract(const cv::Mat& grey8) const = 0;

  // Stable name stored with vocabularies and maps: "surf", "sift", "kaze", "orb".
  virtual const std::string& name() const = 0;
  // Floats (or bytes, for binary descriptors) per descriptor.
  virtual int dim() const = 0;
  virtual DescriptorType type() const = 0;
  // "<name>-<dim>", e.g. "surf-64": what vocabularies and maps record and compare.
  std::string signature() const { return name() + "-" + std::to_string(dim()); }
};

// Builds the extractor named by options.extractor after validateFeatureOptions().
// With for_mapping = true (the vocabulary and map), a binary extractor (ORB) is refused with
// Error(kInvalidArgument): the vocabulary compares descriptors by Euclidean distance only.
// for_mapping = false gives ORB too (benchmarks, experiments).
std::unique_ptr<FeatureExtractor> makeFeatureExtractor(const FeatureOptions& options,
                                                       bool for_mapping = true);

}  // namespace placedb
