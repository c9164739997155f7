#include "filter/bayes_filter.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "placedb/error.h"

namespace placedb {

namespace {

// Below this sigma the non-zero similarities are taken as all equal (see the header).
constexpr double kDegenerateSigma = 1e-9;
// p(I|S=-1) in the degenerate cases: mu/sigma + 1 with the best match one sigma above the mean.
constexpr double kDegenerateNewPlaceLikelihood = 2.0;

std::vector<LocationId> sortedUniqueWm(const std::vector<LocationId>& wm) {
  std::vector<LocationId> sorted = wm;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t k = 0; k < sorted.size(); ++k) {
    if (sorted[k] < 0) {
      throw Error(ErrorCode::kInvalidArgument,
                  "Bayes filter: WM location id " + std::to_string(sorted[k]) + " is negative");
    }
    if (k > 0 && sorted[k] == sorted[k - 1]) {
      throw Error(ErrorCode::kInvalidArgument,
                  "Bayes filter: WM location " + std::to_string(sorted[k]) + " listed twice");
    }
  }
  return sorted;
}

// Index of id in sorted, or -1.
std::ptrdiff_t indexOf(const std::vector<LocationId>& sorted, LocationId id) {
  auto it = std::lower_bound(sorted.begin(), sorted.end(), id);
  if (it == sorted.end() || *it != id) return -1;
  return it - sorted.begin();
}

}  // namespace

const char* toString(RejectReason reason) {
  switch (reason) {
    case RejectReason::kNone:
      return "none";
    case RejectReason::kNoHypothesis:
      return "no_hypothesis";
    case RejectReason::kBelowThreshold:
      return "below_threshold";
    case RejectReason::kRatioTest:
      return "ratio_test";
  }
  return "unknown";
}

BayesFilter::BayesFilter(const BayesFilterSettings& settings)
    : settings_(settings), transitions_(settings) {}

Likelihood BayesFilter::likelihood(const std::vector<double>& similarity_by_location) {
  Likelihood out;
  double sum = 0.0;
  for (double s : similarity_by_location) {
    if (s > 0.0) {
      sum += s;
      ++out.nonzero;
    }
  }
  out.of_location.assign(similarity_by_location.size(), 1.0);
  if (out.nonzero == 0) {
    out.degenerate = true;
    out.new_place = kDegenerateNewPlaceLikelihood;
    return out;
  }
  out.mean = sum / static_cast<double>(out.nonzero);
  double squares = 0.0;
  for (double s : similarity_by_location) {
    if (s > 0.0) squares += (s - out.mean) * (s - out.mean);
  }
  out.stddev = std::sqrt(squares / static_cast<double>(out.nonzero));
  if (out.stddev <= kDegenerateSigma) {
    out.degenerate = true;
    out.new_place = kDegenerateNewPlaceLikelihood;
    return out;
  }
  const double bar = out.mean + out.stddev;
  for (std::size_t k = 0; k < similarity_by_location.size(); ++k) {
    const double s = similarity_by_location[k];
    if (s >= bar) out.of_location[k] = (s - out.stddev) / out.mean;
  }
  out.new_place = out.mean / out.stddev + 1.0;
  return out;
}

std::vector<double> BayesFilter::predictDense(const std::vector<LocationId>& sorted_wm,
                                              const LinkGraph& graph) const {
  const std::size_t m = sorted_wm.size();
  std::vector<double> predicted(m + 1, 0.0);  // [0] is the new place, [k + 1] is sorted_wm[k]

  // Prior: the previous posterior restricted to the current WM (see the header).
  double prior_new_place = 0.0;
  std::vector<std::pair<std::size_t, double>> prior_locations;  // (index in sorted_wm, mass)
  for (const auto& [id, mass] : posterior_) {
    if (id == kNewPlace) {
      prior_new_place = mass;
      continue;
    }
    const std::ptrdiff_t k = indexOf(sorted_wm, id);
    if (k >= 0 && mass > 0.0) prior_locations.emplace_back(static_cast<std::size_t>(k), mass);
  }
  double location_mass = 0.0;
  for (const auto& entry : prior_locations) location_mass += entry.second;
  if (prior_new_place <= 0.0 && location_mass <= 0.0) prior_new_place = 1.0;

  predicted[0] = transitions_.newPlaceStays(m) * prior_new_place +
                 settings_.location_to_new_place * location_mass;
  const double from_new_place = prior_new_place * transitions_.newPlaceToEachLocation(m);
  for (std::size_t k = 0; k < m; ++k) predicted[k + 1] = from_new_place;

  WmNeighbourhoods neighbourhoods(sorted_wm, graph);
  for (const auto& [k, mass] : prior_locations) {
    transitions_.spreadFrom(k, mass, neighbourhoods, predicted);
  }
  return predicted;
}

std::vector<std::pair<LocationId, double>> BayesFilter::predict(const std::vector<LocationId>& wm,
                                                                const LinkGraph& graph) const {
  const std::vector<LocationId> sorted_wm = sortedUniqueWm(wm);
  const std::vector<double> dense = predictDense(sorted_wm, graph);
  std::vector<std::pair<LocationId, double>> out;
  out.reserve(dense.size());
  out.emplace_back(kNewPlace, dense[0]);
  for (std::size_t k = 0; k < sorted_wm.size(); ++k) out.emplace_back(sorted_wm[k], dense[k + 1]);
  return out;
}

FilterOutcome BayesFilter::update(const std::vector<LocationId>& wm,
                                  const std::vector<LocationSimilarity>& similarities,
                                  const LinkGraph& graph) {
  std::vector<std::pair<LocationId, double>> pairs;
  pairs.reserve(similarities.size());
  for (const auto& s : similarities) pairs.emplace_back(s.location, s.similarity);
  return update(wm, pairs, graph);
}

FilterOutcome BayesFilter::update(const std::vector<LocationId>& wm,
                                  const std::vector<std::pair<LocationId, double>>& similarities,
                                  const LinkGraph& graph) {
  const std::vector<LocationId> sorted_wm = sortedUniqueWm(wm);
  std::vector<double> sims(sorted_wm.size(), 0.0);
  for (const auto& [id, sim] : similarities) {
    const std::ptrdiff_t k = indexOf(sorted_wm, id);
    if (k < 0) {
      throw Error(ErrorCode::kInvalidArgument, "Bayes filter: similarity given for location " +
                                                   std::to_string(id) + ", which is not in WM");
    }
    if (!(sim >= 0.0 && sim <= 1.0)) {
      throw Error(ErrorCode::kInvalidArgument, "Bayes filter: similarity " + std::to_string(sim) +
                                                   " of location " + std::to_string(id) +
                                                   " is outside [0, 1]");
    }
    sims[static_cast<std::size_t>(k)] = sim;
  }

  FilterOutcome outcome;
  outcome.likelihood = likelihood(sims);
  std::vector<double> joint = predictDense(sorted_wm, graph);
  joint[0] *= outcome.likelihood.new_place;
  for (std::size_t k = 0; k < sorted_wm.size(); ++k) {
    joint[k + 1] *= outcome.likelihood.of_location[k];
  }
  double total = 0.0;
  for (double v : joint) total += v;
  if (!(total > 0.0) || !std::isfinite(total)) {
    throw Error(ErrorCode::kInternal,
                "Bayes filter: posterior mass " + std::to_string(total) + " cannot be normalised");
  }

  posterior_.clear();
  posterior_.reserve(joint.size());
  posterior_.emplace_back(kNewPlace, joint[0] / total);
  for (std::size_t k = 0; k < sorted_wm.size(); ++k) {
    posterior_.emplace_back(sorted_wm[k], joint[k + 1] / total);
  }
  decide(outcome);
  return outcome;
}

void BayesFilter::decide(FilterOutcome& outcome) {
  outcome.new_place_posterior = posterior_.front().second;
  outcome.previous_score = previous_score_;
  outcome.hypothesis = kNewPlace;
  outcome.hypothesis_posterior = 0.0;
  // Ids ascend, so keeping only strictly larger values resolves ties to the smaller id.
  for (std::size_t k = 1; k < posterior_.size(); ++k) {
    if (outcome.hypothesis == kNewPlace || posterior_[k].second > outcome.hypothesis_posterior) {
      outcome.hypothesis = posterior_[k].first;
      outcome.hypothesis_posterior = posterior_[k].second;
    }
  }
  outcome.accepted = false;
  if (outcome.hypothesis == kNewPlace) {
    outcome.score = 0.0;
    outcome.reason = RejectReason::kNoHypothesis;
  } else {
    outcome.score = 1.0 - outcome.new_place_posterior;
    if (settings_.rule == DecisionRule::kPaper) {
      outcome.reason = outcome.new_place_posterior < settings_.t_loop
                           ? RejectReason::kNone
                           : RejectReason::kBelowThreshold;
    } else if (outcome.score < settings_.t_loop) {
      outcome.reason = RejectReason::kBelowThreshold;
    } else if (settings_.loop_ratio > 0.0 &&
               outcome.score < settings_.loop_ratio * previous_score_) {
      outcome.reason = RejectReason::kRatioTest;
    } else {
      outcome.reason = RejectReason::kNone;
    }
    outcome.accepted = outcome.reason == RejectReason::kNone;
  }
  previous_score_ = outcome.score;
}

double BayesFilter::posteriorOf(LocationId id) const {
  auto it = std::lower_bound(
      posterior_.begin(), posterior_.end(), id,
      [](const std::pair<LocationId, double>& e, LocationId key) { return e.first < key; });
  return (it != posterior_.end() && it->first == id) ? it->second : 0.0;
}

void BayesFilter::restore(const FilterState& state) {
  for (std::size_t k = 0; k < state.posterior.size(); ++k) {
    const auto& [id, mass] = state.posterior[k];
    if (id < kNewPlace || (k > 0 && state.posterior[k - 1].first >= id)) {
      throw Error(ErrorCode::kInvalidArgument,
                  "Bayes filter state: posterior ids must be >= -1, sorted and unique (entry " +
                      std::to_string(k) + ", id " + std::to_string(id) + ")");
    }
    if (!(mass >= 0.0) || !std::isfinite(mass)) {
      throw Error(ErrorCode::kInvalidArgument, "Bayes filter state: posterior of location " +
                                                   std::to_string(id) + " is " +
                                                   std::to_string(mass));
    }
  }
  if (!(state.previous_score >= 0.0 && state.previous_score <= 1.0)) {
    throw Error(ErrorCode::kInvalidArgument, "Bayes filter state: previous score " +
                                                 std::to_string(state.previous_score) +
                                                 " is outside [0, 1]");
  }
  posterior_ = state.posterior;
  previous_score_ = state.previous_score;
}

}  // namespace placedb
