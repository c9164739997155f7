#pragma once
// Settings of the Bayes filter and its decision rule. Those a user can set default to Options
// (placedb/options.h); the transition probabilities are RTAB-Map's (T-RO 2013).
#include "placedb/options.h"

namespace placedb {

struct BayesFilterSettings {
  double new_place_stays = 0.9;        // p(S_t=-1 | S_{t-1}=-1); p(i|-1) = (1 - this) / M
  double location_to_new_place = 0.1;  // p(S_t=-1 | S_{t-1}=j); the rest spreads around j
  double prediction_sigma = Options().prediction_sigma;  // links, the Gaussian around j
  int prediction_links = Options().prediction_links;  // the Gaussian reaches this many links from j
  DecisionRule rule = Options().decision_rule;
  double t_loop = Options().t_loop;          // T_loop
  double loop_ratio = Options().loop_ratio;  // ratio test of kRtabmap; 0 turns it off

  // kInvalidArgument naming every out-of-range field and its valid range; accepts at least
  // what Options::validate() accepts (options_test).
  void validate() const;
};

}  // namespace placedb
