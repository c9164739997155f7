#pragma once
// Geometric checks of a frame's loop candidates, two at a time. chooseCandidate
// (decision/candidate_choice.h) asks for candidates one by one, most likely first, and stops at
// the first that passes. A frame whose first candidate passes checks one; a frame whose first
// fails most often goes on to check every candidate (the place-code search's, the filter's
// neighbours, those near the last closure), and those checks are most of the slowest frames'
// cost. So from the second candidate on, the next candidate in order is checked on another core
// while the one asked for is checked on this one, and its result waits for chooseCandidate to ask.
// Each check is a pure function of the two views (checkGeometry draws its own fixed-seed
// samples), and a result made ahead that is never asked for is dropped: the choice is the one of
// checks made one by one, on any number of threads.
#include <cstddef>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <vector>

#include "filter/bayes_filter.h"
#include "geometry/geometry.h"

namespace placedb {

class PairedChecks {
 public:
  // The view of a candidate, read on the calling thread (it may read the map); nothing when the
  // candidate has no keypoints, which chooseCandidate skips.
  using Prepare = std::function<std::optional<GeometricView>(LocationId)>;
  // The check of a prepared view; called from two threads at once.
  using Check = std::function<GeometricResult(const GeometricView&)>;

  // `order`: the candidates in the order chooseCandidate walks them. One thread: one by one.
  PairedChecks(std::vector<LocationId> order, int threads, Prepare prepare, Check check);

  // The check of `candidate`, made now or taken from a check made ahead.
  std::optional<GeometricResult> operator()(LocationId candidate);

  // Checks made ahead so far, asked for or not (tests).
  std::size_t madeAhead() const { return made_ahead_; }

 private:
  // The first candidate after `candidate` in order that is neither asked for nor checked ahead.
  std::optional<LocationId> nextAfter(LocationId candidate) const;

  std::vector<LocationId> order_;
  int threads_ = 1;
  Prepare prepare_;
  Check check_;
  std::set<LocationId> asked_;
  std::map<LocationId, std::optional<GeometricResult>> ahead_;
  std::size_t made_ahead_ = 0;
};

}  // namespace placedb
