#include "filter/transition_model.h"

#include <cmath>

namespace placedb {

TransitionModel::TransitionModel(const BayesFilterSettings& settings) : settings_(settings) {
  settings_.validate();
  const double two_sigma_sq = 2.0 * settings_.gaussian_sigma * settings_.gaussian_sigma;
  for (int d = 0; d <= settings_.neighbourhood_links; ++d) {
    weight_by_links_.push_back(std::exp(-static_cast<double>(d) * d / two_sigma_sq));
  }
}

PredictionRow TransitionModel::fromLocation(LocationId j, const LinkGraph& graph,
                                            const LinkGraph::NodeFilter& in_wm) const {
  PredictionRow row;
  row.to_new_place = settings_.location_to_new_place;
  auto reach = graph.withinLinks(j, settings_.neighbourhood_links, in_wm);
  if (reach.empty()) reach.emplace_back(j, 0);
  // Summed in id order (reach is sorted) so the row is the same bit for bit on every run.
  double total = 0.0;
  for (const auto& [id, links] : reach) total += weightAt(links);
  const double share = 1.0 - settings_.location_to_new_place;
  row.to_locations.reserve(reach.size());
  for (const auto& [id, links] : reach) {
    row.to_locations.emplace_back(id, share * weightAt(links) / total);
  }
  return row;
}

double TransitionModel::newPlaceStays(std::size_t wm_size) const {
  return wm_size == 0 ? 1.0 : settings_.new_place_stays;
}

double TransitionModel::newPlaceToEachLocation(std::size_t wm_size) const {
  return wm_size == 0 ? 0.0 : (1.0 - settings_.new_place_stays) / static_cast<double>(wm_size);
}

}  // namespace placedb
