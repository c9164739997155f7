#pragma once
// Settings of the Bayes filter and its decision rule, with the published defaults
// (paper 000 table 4 and RTAB-Map, T-RO 2013).
#include <string>

namespace placedb {

enum class DecisionRule {
  // Accept when 1 - p(S_t=-1|I^t) >= T_loop, unless that score fell under loop_ratio times the
  // previous update's score (RTAB-Map, 2013 settings). The default.
  kRtabmap,
  // Accept when p(S_t=-1|I^t) < T_loop (paper 000's wording). No ratio test.
  kPaper000,
};

const char* toString(DecisionRule rule);
// "rtabmap" or "paper000"; kInvalidArgument otherwise.
DecisionRule parseDecisionRule(const std::string& name);

struct BayesFilterSettings {
  double new_place_stays = 0.9;        // p(S_t=-1 | S_{t-1}=-1); p(i|-1) = (1 - this) / M
  double location_to_new_place = 0.1;  // p(S_t=-1 | S_{t-1}=j); the rest spreads around j
  double gaussian_sigma = 1.6;         // in links, of the discrete Gaussian around j
  int neighbourhood_links = 16;  // the Gaussian reaches locations up to this many links from j
  DecisionRule rule = DecisionRule::kRtabmap;
  double loop_threshold = 0.11;  // T_loop
  double loop_ratio = 0.9;       // ratio test of kRtabmap; 0 turns it off

  // kInvalidArgument naming every out-of-range field and its valid range.
  void validate() const;
};

}  // namespace placedb
