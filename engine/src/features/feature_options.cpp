#include "features/feature_options.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <thread>

#include "placedb/error.h"

namespace placedb {
namespace {

template <typename T>
void requireInRange(const char* name, T value, T low, T high, const char* range_text) {
  bool ok = value >= low && value <= high;
  if constexpr (std::is_floating_point_v<T>) ok = ok && std::isfinite(value);
  if (!ok) {
    std::ostringstream message;
    message << "feature option " << name << " = " << value
            << " is out of range; valid: " << range_text;
    throw Error(ErrorCode::kInvalidArgument, message.str());
  }
}

}  // namespace

const std::vector<std::string>& knownExtractorNames() {
  static const std::vector<std::string> names = {"surf", "sift", "kaze", "orb"};
  return names;
}

void validateFeatureOptions(const FeatureOptions& options) {
  const auto& names = knownExtractorNames();
  if (std::find(names.begin(), names.end(), options.extractor) == names.end()) {
    throw Error(ErrorCode::kInvalidArgument, "feature option extractor = '" + options.extractor +
                                                 "' is unknown; valid: surf, sift, kaze, orb");
  }
  requireInRange("hessian_threshold", options.hessian_threshold, 0.0, 1e12, "[0, 1e12]");
  if (options.edge_ratio != 0.0) {
    requireInRange("edge_ratio", options.edge_ratio, 1.0, 100.0, "0 (off) or [1, 100]");
  }
  requireInRange("octaves", options.octaves, 1, 8, "[1, 8]");
  requireInRange("intervals", options.intervals, 1, 8, "[1, 8]");
  requireInRange("max_features", options.max_features, 0, 1000000, "[0, 1000000], 0 = no limit");
  requireInRange("feature_target", options.feature_target, 0, 1000000, "[0, 1000000], 0 = off");
  requireInRange("feature_retry", options.feature_retry, 0.0, 1.0, "[0, 1], 0 = off");
  requireInRange("min_response", options.min_response, 0.0f, 1e30f, "[0, 1e30]");
  requireInRange("threads", options.threads, 0, 64, "[0, 64], 0 = all hardware threads");
  requireInRange("sift_contrast_threshold", options.sift_contrast_threshold, 1e-9, 1.0, "(0, 1]");
  requireInRange("kaze_threshold", options.kaze_threshold, 1e-9, 1.0, "(0, 1]");
  requireInRange("orb_fast_threshold", options.orb_fast_threshold, 1, 255, "[1, 255]");
}

int resolveThreadCount(int threads) {
  if (threads > 0) return threads;
  return std::max(1u, std::thread::hardware_concurrency());
}

}  // namespace placedb
