#include "filter/filter_settings.h"

#include <cmath>
#include <sstream>

#include "placedb/error.h"

namespace placedb {

namespace {
// NaN fails every comparison, so "inside" is written to be false for it.
bool openUnit(double v) { return v > 0.0 && v < 1.0; }
}  // namespace

void BayesFilterSettings::validate() const {
  std::ostringstream problems;
  if (!openUnit(new_place_stays)) {
    problems << " new_place_stays=" << new_place_stays << " (valid: 0 < x < 1);";
  }
  if (!openUnit(location_to_new_place)) {
    problems << " location_to_new_place=" << location_to_new_place << " (valid: 0 < x < 1);";
  }
  if (!(prediction_sigma > 0.0) || !std::isfinite(prediction_sigma)) {
    problems << " prediction_sigma=" << prediction_sigma << " (valid: finite, > 0);";
  }
  if (prediction_links < 0 || prediction_links > 1000) {
    problems << " prediction_links=" << prediction_links << " (valid: 0..1000);";
  }
  if (rule != DecisionRule::kRtabmap && rule != DecisionRule::kPaper) {
    problems << " rule=" << static_cast<int>(rule) << " (valid: rtabmap, paper);";
  }
  if (!(t_loop >= 0.0 && t_loop <= 1.0)) {
    problems << " t_loop=" << t_loop << " (valid: 0 <= x <= 1);";
  }
  if (!(loop_ratio >= 0.0 && loop_ratio <= 1.0)) {
    problems << " loop_ratio=" << loop_ratio << " (valid: 0 <= x <= 1, 0 disables);";
  }
  const std::string text = problems.str();
  if (!text.empty()) {
    throw Error(ErrorCode::kInvalidArgument, "invalid Bayes filter settings:" + text);
  }
}

}  // namespace placedb
