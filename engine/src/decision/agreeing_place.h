#pragma once
// Which place an accepted loop closure names. The candidates are checked most likely first and
// the first that passes ends the search (candidate_choice.h), so the place accepted is the first
// one good enough, not the best: the filter's hypothesis trails the camera when a revisit moves
// faster than its prediction, and a view a frame or two behind still passes. Once a closure is
// accepted, the accepted place and its traversal neighbours are compared by the pairs each
// agrees on with the frame, and the closure names the one with the most: the view taken from
// where the camera stands shares the most of the scene with it. A place of several frames is
// compared by the better of its views, its first frame's and its latest merged frame's
// (geometry/latest_view.h). The comparison only moves the closure to a neighbour with strictly
// more agreeing pairs, so a tie keeps the place accepted.
#include <functional>
#include <optional>
#include <vector>

#include "filter/signature.h"
#include "geometry/geometry.h"

namespace placedb {

struct AgreeingPlace {
  LocationId location = 0;
  GeometricResult result;  // its comparison check
};

// `compare` checks a place for comparison (every one alike: compareGeometry, geometric_check.h,
// on each of its views) and returns nothing for a place without keypoints; its second argument is
// the count a neighbour has to reach (the best one's plus one, 0 for the accepted place), below
// which the check may spare its fit and return a bound instead. Nothing when the accepted place
// itself cannot be compared. Neighbours are compared in the order given; of two with the same
// count, the first.
using ComparisonCheck = std::function<std::optional<GeometricResult>(LocationId, int)>;
std::optional<AgreeingPlace> mostAgreeingPlace(LocationId accepted,
                                               const std::vector<LocationId>& neighbours,
                                               const ComparisonCheck& compare);

}  // namespace placedb
