#pragma once
// Discrete Bayes filter over S_t in {-1 (new place), i in WM} (SPEC section 6), with the
// likelihood of paper 000 eqs. 8-9, the sparse banded prediction of eq. 11 and the decision rule.
//
// Choices the papers leave open, fixed here:
// - mu and sigma are the mean and the population standard deviation (divide by n) of the
//   non-zero similarities of WM locations.
// - Degenerate likelihoods: with no non-zero similarity, or sigma <= 1e-9 (all non-zero
//   similarities equal), no location is favoured (every p(I|S=i) = 1) and p(I|S=-1) = 2, the
//   value of mu/sigma + 1 when the best match sits one sigma above the mean: the frame leans
//   towards "new place" without the infinite weight mu/0 would give.
// - A location that left WM since the last update drops out of the prior. The posterior is
//   normalised after the product anyway, so dropping is the same as renormalising the prior over
//   what remains. If nothing remains (first update, or all mass left), the prior is p(-1) = 1.
// - New WM locations have prior 0; they still receive mass through the prediction.
// - "Previous score" for the ratio test is the score of the previous update() call, accepted or
//   not. After an update with an empty WM (no hypothesis), and on the very first update, it is 0,
//   so the ratio test cannot reject the next frame.
#include <cstdint>
#include <utility>
#include <vector>

#include "filter/filter_settings.h"
#include "filter/inverted_index.h"
#include "filter/link_graph.h"
#include "filter/transition_model.h"

namespace placedb {

inline constexpr LocationId kNewPlace = -1;

enum class RejectReason {
  kNone,            // accepted
  kNoHypothesis,    // WM was empty
  kBelowThreshold,  // the rule's threshold test failed
  kRatioTest,       // kRtabmap only: score < loop_ratio x previous score
};
const char* toString(RejectReason reason);

struct Likelihood {
  double mean = 0.0;    // mu over the non-zero similarities
  double stddev = 0.0;  // sigma over the same
  std::size_t nonzero = 0;
  bool degenerate = false;          // no non-zero similarity, or sigma ~ 0
  double new_place = 1.0;           // p(I_t | S_t=-1)
  std::vector<double> of_location;  // p(I_t | S_t=i), WM ids ascending (as posterior())
};

// The whole filter state: restoring it makes the next updates bit-identical to an uninterrupted
// run.
struct FilterState {
  std::vector<std::pair<LocationId, double>> posterior;  // sorted by id; kNewPlace first if present
  double previous_score = 0.0;
  bool operator==(const FilterState& o) const {
    return posterior == o.posterior && previous_score == o.previous_score;
  }
};

struct FilterOutcome {
  LocationId hypothesis = kNewPlace;  // argmax_{i >= 0} posterior, smaller id on ties
  double hypothesis_posterior = 0.0;  // p(S_t = hypothesis | I^t)
  double new_place_posterior = 1.0;   // p(S_t = -1 | I^t)
  double score = 0.0;                 // 1 - new_place_posterior, 0 without hypothesis
  double previous_score = 0.0;        // what the ratio test compared with
  bool accepted = false;
  RejectReason reason = RejectReason::kNoHypothesis;
  Likelihood likelihood;
};

class BayesFilter {
 public:
  explicit BayesFilter(const BayesFilterSettings& settings = {});  // validates

  // One frame. wm: ids of the WM locations (the loop candidates; any order, no repeats).
  // similarities: sim_i of WM locations (absent ones are 0); an id outside WM or a value outside
  // [0, 1] is kInvalidArgument. graph: links between locations; the prediction only walks
  // through WM locations.
  FilterOutcome update(const std::vector<LocationId>& wm,
                       const std::vector<std::pair<LocationId, double>>& similarities,
                       const LinkGraph& graph);
  FilterOutcome update(const std::vector<LocationId>& wm,
                       const std::vector<LocationSimilarity>& similarities, const LinkGraph& graph);

  // p(S_t | I^{t-1}) for the given WM from the current state, kNewPlace first then WM ids sorted.
  // Sums to 1 unless part of the previous posterior left WM.
  std::vector<std::pair<LocationId, double>> predict(const std::vector<LocationId>& wm,
                                                     const LinkGraph& graph) const;

  // Likelihood of paper 000 eqs. 8-9 for sorted unique WM ids and their similarities
  // (aligned; 0 for no shared word).
  static Likelihood likelihood(const std::vector<double>& similarity_by_location);

  const std::vector<std::pair<LocationId, double>>& posterior() const { return posterior_; }
  double posteriorOf(LocationId id) const;  // 0 when absent
  FilterState state() const { return {posterior_, previous_score_}; }
  void restore(const FilterState& state);  // kInvalidArgument when unsorted, negative or NaN
  void reset() { restore({}); }
  const BayesFilterSettings& settings() const { return settings_; }

 private:
  std::vector<double> predictDense(const std::vector<LocationId>& sorted_wm,
                                   const LinkGraph& graph) const;
  void decide(FilterOutcome& outcome);

  BayesFilterSettings settings_;
  TransitionModel transitions_;
  std::vector<std::pair<LocationId, double>> posterior_;
  double previous_score_ = 0.0;
};

}  // namespace placedb
