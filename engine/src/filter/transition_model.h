#pragma once
// Rows of the filter's prediction matrix p(S_t | S_{t-1}), built on demand and kept sparse: a row
// from a location only names the WM locations within neighbourhood_links links of it.
#include <utility>
#include <vector>

#include "filter/filter_settings.h"
#include "filter/link_graph.h"

namespace placedb {

struct PredictionRow {
  double to_new_place = 0.0;                                // p(S_t=-1 | S_{t-1}=j)
  std::vector<std::pair<LocationId, double>> to_locations;  // p(S_t=i | S_{t-1}=j), sorted by i
};

class TransitionModel {
 public:
  explicit TransitionModel(const BayesFilterSettings& settings);

  // Row of a location j in WM. The locations within neighbourhood_links links of j, walking only
  // through WM locations, share 1 - location_to_new_place in proportion to
  // exp(-d^2 / (2 sigma^2)), d = links from j (j itself has d = 0). A j missing from the graph
  // counts as isolated and keeps the whole share.
  PredictionRow fromLocation(LocationId j, const LinkGraph& graph,
                             const LinkGraph::NodeFilter& in_wm) const;

  // Row of the new place: it stays with new_place_stays, the rest split evenly over wm_size.
  // When WM is empty the new place keeps everything.
  double newPlaceStays(std::size_t wm_size) const;
  double newPlaceToEachLocation(std::size_t wm_size) const;

  // Unnormalised Gaussian weight at d links (d in 0..neighbourhood_links).
  double weightAt(int links) const { return weight_by_links_.at(static_cast<std::size_t>(links)); }

 private:
  BayesFilterSettings settings_;
  std::vector<double> weight_by_links_;
};

}  // namespace placedb
