#include "memory/place_neighbourhood.h"

#include <algorithm>

namespace placedb {

PlaceNeighbourhood::PlaceNeighbourhood(
    const PlaceIndex& index, const std::vector<std::pair<std::int64_t, std::int64_t>>& links)
    : index_(index) {
  const std::size_t n = index.size();
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  pairs.reserve(2 * links.size());
  for (const auto& [a, b] : links) {
    const std::size_t ra = index.rowOf(a), rb = index.rowOf(b);
    if (ra == n || rb == n || ra == rb) continue;
    pairs.emplace_back(ra, rb);
    pairs.emplace_back(rb, ra);
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  first_.assign(n + 1, 0);
  for (const auto& p : pairs) ++first_[p.first + 1];
  for (std::size_t r = 0; r < n; ++r) first_[r + 1] += first_[r];
  rows_.reserve(pairs.size());
  for (const auto& p : pairs) rows_.push_back(p.second);
}

std::vector<PlaceMatch> PlaceNeighbourhood::search(
    const std::vector<double>& likeness, std::size_t k,
    const std::function<bool(std::int64_t)>& admit) const {
  std::vector<PlaceMatch> best;
  const std::size_t n = first_.size() - 1;
  if (k == 0 || likeness.size() != n) return best;
  best.reserve(k + 1);
  for (std::size_t r = 0; r < n; ++r) {
    double sum = likeness[r];
    for (std::size_t i = first_[r]; i < first_[r + 1]; ++i) sum += likeness[rows_[i]];
    offerMatch(best, k, {index_.idAt(r), sum / double(1 + first_[r + 1] - first_[r])}, admit);
  }
  return best;
}

}  // namespace placedb
