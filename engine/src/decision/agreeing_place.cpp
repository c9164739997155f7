#include "decision/agreeing_place.h"

namespace placedb {

std::optional<AgreeingPlace> mostAgreeingPlace(LocationId accepted,
                                               const std::vector<LocationId>& neighbours,
                                               const ComparisonCheck& compare) {
  std::optional<GeometricResult> own = compare(accepted, 0);
  if (!own) return std::nullopt;
  AgreeingPlace best{accepted, std::move(*own)};
  for (LocationId n : neighbours) {
    if (n == accepted) continue;
    std::optional<GeometricResult> g = compare(n, best.result.inliers + 1);
    if (g && g->inliers > best.result.inliers) best = {n, std::move(*g)};
  }
  return best;
}

}  // namespace placedb
