#include "features/feature_extractor.h"

#include "features/opencv_extractors.h"
#include "features/surf_extractor.h"
#include "placedb/error.h"

namespace placedb {

std::unique_ptr<FeatureExtractor> makeFeatureExtractor(const FeatureOptions& options,
                                                       bool for_mapping) {
  validateFeatureOptions(options);
  if (options.extractor == "surf") return std::make_unique<SurfExtractor>(options);
  if (options.extractor == "sift") return std::make_unique<SiftExtractor>(options);
  if (options.extractor == "kaze") return std::make_unique<KazeExtractor>(options);
  if (options.extractor == "orb") {
    if (for_mapping) {
      throw Error(ErrorCode::kInvalidArgument,
                  "extractor 'orb' gives binary descriptors compared by Hamming distance, but the "
                  "vocabulary compares float descriptors by Euclidean distance only; use surf, "
                  "sift or kaze for mapping");
    }
    return std::make_unique<OrbExtractor>(options);
  }
  throw Error(ErrorCode::kInternal, "extractor '" + options.extractor + "' passed validation");
}

}  // namespace placedb
