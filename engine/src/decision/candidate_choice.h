#pragma once
// Which of a frame's loop-closure candidates its hypothesis names, given the geometric check.
//
// The candidates: the filter's best location, the WM locations within a few links of it, the
// WM locations most similar by eq. 5, those the place-code search brought back from LTM in
// this very frame, and the neighbourhood of the last accepted closure. The searched-back ones
// are there in their own right because eq. 5 cannot rank them yet: the frame was quantised
// before their words came back to the vocabulary, so it shares few words with them.
//
// Candidates come most likely first and the first one that passes ends the search: checking is
// most of a frame's cost. Two exceptions keep a revisit on track:
//  - a candidate within reach of the last accepted closure (near) that misses the check's rule
//    still passes a relaxed one, when no candidate passes on its own;
//  - a candidate that passes but jumps away from the ongoing closure has to beat its
//    continuation: the near candidates the early exit skipped are checked too, and the
//    continuation is kept when it passes (even relaxed) with at least the jump's strength. A
//    forward-moving camera sees a street's facades from several places along it, so a passing
//    jump is often a few places off while the continuation follows the camera.
#include <functional>
#include <optional>
#include <vector>

#include "filter/bayes_filter.h"
#include "geometry/geometry.h"

namespace placedb {

struct CandidateSources {
  LocationId hypothesis = kNewPlace;          // the filter's best
  std::vector<LocationId> around;             // WM locations near it, nearest first
  std::vector<LocationId> most_similar;       // WM locations by eq. 5, best first
  std::vector<LocationId> searched_back;      // brought back from LTM by the place codes
  std::vector<LocationId> near_last_closure;  // sorted
};

// Every source's locations once, most likely first: the hypothesis, then the others by
// `similarity` (eq. 5), ties by id.
std::vector<LocationId> orderCandidates(const CandidateSources& sources,
                                        const std::function<double(LocationId)>& similarity);

struct CandidateChoice {
  LocationId location = kNewPlace;        // when no candidate could be checked
  std::optional<GeometricResult> result;  // the chosen candidate's check
  bool passed = false;                    // by the check's rule, or relaxed near the closure
  bool temporal = false;                  // passed only on the relaxed rule
  int checked = 0;                        // candidates the check ran on
};

// `check` returns nothing for a candidate with no keypoints (it is skipped); `near` is sorted;
// `passes_relaxed` is the relaxed rule for near candidates.
using CandidateCheck = std::function<std::optional<GeometricResult>(LocationId)>;
CandidateChoice chooseCandidate(const std::vector<LocationId>& ordered,
                                const std::vector<LocationId>& near, GeometryRule rule,
                                const CandidateCheck& check,
                                const std::function<bool(const GeometricResult&)>& passes_relaxed);

}  // namespace placedb
