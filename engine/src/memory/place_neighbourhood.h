#pragma once
// Ranks places by their neighbourhood: a location's code likeness averaged with that of the
// locations linked to it along the traversal (neighbour links, not loop closures).
//
// Why: a place code describes one image, and one image of a place is a noisy sample of it; the
// frames either side of it see the same ground. On the 100k-frame scale map, 14 queried frames
// that had merged into the location of the frame before them ranked their location 1st to
// 2,030th of 51,645 by its centred code, and by the neighbourhood mean within the first 55 for
// 13 of the 14 (bench/scale/README.md). Look-alikes elsewhere are single images; the right place
// is a short run of them, as in sequence matching (SeqSLAM, Milford and Wyeth 2012).
//
// Built once for an index that no longer changes (a map opened for localisation).
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "memory/place_index.h"

namespace placedb {

class PlaceNeighbourhood {
 public:
  // Links between locations of `index` (either way round); locations without a code are ignored.
  PlaceNeighbourhood(const PlaceIndex& index,
                     const std::vector<std::pair<std::int64_t, std::int64_t>>& links);

  // The k locations with the highest mean of `likeness` (by row of the index, as
  // PlaceIndex::centredSimilarities gives it) over themselves and their linked locations, among
  // those `admit` accepts; highest first, the smaller id first on ties.
  std::vector<PlaceMatch> search(const std::vector<double>& likeness, std::size_t k,
                                 const std::function<bool(std::int64_t)>& admit) const;

 private:
  const PlaceIndex& index_;
  std::vector<std::size_t> first_;  // row r's linked rows: rows_[first_[r], first_[r + 1])
  std::vector<std::size_t> rows_;
};

}  // namespace placedb
