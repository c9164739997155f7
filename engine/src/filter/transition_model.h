#pragma once
// Rows of the filter's prediction matrix p(S_t | S_{t-1}), built on demand and kept sparse: a row
// from a location only names the WM locations within prediction_links links of it.
#include <cstdint>
#include <utility>
#include <vector>

#include "filter/filter_settings.h"
#include "filter/link_graph.h"

namespace placedb {

struct PredictionRow {
  double to_new_place = 0.0;                                // p(S_t=-1 | S_{t-1}=j)
  std::vector<std::pair<LocationId, double>> to_locations;  // p(S_t=i | S_{t-1}=j), sorted by i
};

// The link graph restricted to WM as compact adjacency lists over positions in the sorted WM, built
// once per frame so that the many walks of one prediction avoid map lookups and allocations.
class WmNeighbourhoods {
 public:
  WmNeighbourhoods(const std::vector<LocationId>& sorted_wm, const LinkGraph& graph);
  // Positions within max_depth links of position k (k itself at depth 0), in no set order; valid
  // until the next call. countByDepth() then holds how many positions sit at each depth.
  const std::vector<std::pair<std::uint32_t, int>>& reach(std::size_t k, int max_depth);
  const std::vector<int>& countByDepth() const { return count_by_depth_; }

 private:
  std::vector<std::pair<std::uint32_t, int>> reach_;
  std::vector<int> count_by_depth_;
  std::vector<std::size_t> offsets_;  // neighbours of k: targets_[offsets_[k] .. offsets_[k+1])
  std::vector<std::uint32_t> targets_;
  std::vector<std::uint32_t> seen_mark_;  // == walk_ when visited by the current walk
  std::uint32_t walk_ = 0;
};

class TransitionModel {
 public:
  explicit TransitionModel(const BayesFilterSettings& settings);

  // Row of a location j in WM. The locations within prediction_links links of j, walking only
  // through WM locations, share 1 - location_to_new_place in proportion to
  // exp(-d^2 / (2 sigma^2)), d = links from j (j itself has d = 0). A j missing from the graph
  // counts as isolated and keeps the whole share.
  PredictionRow fromLocation(LocationId j, const LinkGraph& graph,
                             const LinkGraph::NodeFilter& in_wm) const;

  // Adds mass x row(sorted_wm[k]) to predicted[i + 1] for every position i of the row: the same
  // values as fromLocation(), bit for bit, without building the row.
  void spreadFrom(std::size_t k, double mass, WmNeighbourhoods& neighbourhoods,
                  std::vector<double>& predicted) const;

  // Row of the new place: it stays with new_place_stays, the rest split evenly over wm_size.
  // When WM is empty the new place keeps everything.
  double newPlaceStays(std::size_t wm_size) const;
  double newPlaceToEachLocation(std::size_t wm_size) const;

  // Unnormalised Gaussian weight at d links (d in 0..prediction_links).
  double weightAt(int links) const { return weight_by_links_.at(static_cast<std::size_t>(links)); }

 private:
  // Sum of the Gaussian weights of a row, from how many locations sit at each depth; summed by
  // depth so the result does not depend on how the row was found.
  double rowTotal(const std::vector<int>& count_by_links) const;

  BayesFilterSettings settings_;
  std::vector<double> weight_by_links_;
};

}  // namespace placedb
