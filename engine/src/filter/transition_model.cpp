#include "filter/transition_model.h"

#include <algorithm>
#include <cmath>

namespace placedb {

WmNeighbourhoods::WmNeighbourhoods(const std::vector<LocationId>& sorted_wm,
                                   const LinkGraph& graph) {
  offsets_.reserve(sorted_wm.size() + 1);
  offsets_.push_back(0);
  for (LocationId id : sorted_wm) {
    for (LocationId next : graph.neighbourSet(id)) {
      auto it = std::lower_bound(sorted_wm.begin(), sorted_wm.end(), next);
      if (it != sorted_wm.end() && *it == next) {
        targets_.push_back(static_cast<std::uint32_t>(it - sorted_wm.begin()));
      }
    }
    offsets_.push_back(targets_.size());
  }
  seen_mark_.assign(sorted_wm.size(), 0);
}

const std::vector<std::pair<std::uint32_t, int>>& WmNeighbourhoods::reach(std::size_t k,
                                                                          int max_depth) {
  auto& out = reach_;
  out.clear();
  count_by_depth_.assign(static_cast<std::size_t>(max_depth) + 1, 0);
  if (++walk_ == 0) {  // the marks wrapped around: start them afresh
    std::fill(seen_mark_.begin(), seen_mark_.end(), 0);
    walk_ = 1;
  }
  out.emplace_back(static_cast<std::uint32_t>(k), 0);
  seen_mark_[k] = walk_;
  // `out` doubles as the breadth-first queue.
  for (std::size_t head = 0; head < out.size(); ++head) {
    const auto [node, depth] = out[head];
    ++count_by_depth_[static_cast<std::size_t>(depth)];
    if (depth == max_depth) continue;
    for (std::size_t e = offsets_[node]; e < offsets_[node + 1]; ++e) {
      const std::uint32_t next = targets_[e];
      if (seen_mark_[next] == walk_) continue;
      seen_mark_[next] = walk_;
      out.emplace_back(next, depth + 1);
    }
  }
  return out;
}

TransitionModel::TransitionModel(const BayesFilterSettings& settings) : settings_(settings) {
  settings_.validate();
  const double two_sigma_sq = 2.0 * settings_.prediction_sigma * settings_.prediction_sigma;
  for (int d = 0; d <= settings_.prediction_links; ++d) {
    weight_by_links_.push_back(std::exp(-static_cast<double>(d) * d / two_sigma_sq));
  }
}

double TransitionModel::rowTotal(const std::vector<int>& count_by_links) const {
  double total = 0.0;
  for (std::size_t d = 0; d < count_by_links.size(); ++d) {
    total += count_by_links[d] * weight_by_links_[d];
  }
  return total;
}

PredictionRow TransitionModel::fromLocation(LocationId j, const LinkGraph& graph,
                                            const LinkGraph::NodeFilter& in_wm) const {
  PredictionRow row;
  row.to_new_place = settings_.location_to_new_place;
  auto reach = graph.withinLinks(j, settings_.prediction_links, in_wm);
  if (reach.empty()) reach.emplace_back(j, 0);
  std::vector<int> count_by_links(weight_by_links_.size(), 0);
  for (const auto& entry : reach) ++count_by_links[static_cast<std::size_t>(entry.second)];
  const double total = rowTotal(count_by_links);
  const double share = 1.0 - settings_.location_to_new_place;
  row.to_locations.reserve(reach.size());
  for (const auto& [id, links] : reach) {
    row.to_locations.emplace_back(id, share * weightAt(links) / total);
  }
  return row;
}

void TransitionModel::spreadFrom(std::size_t k, double mass, WmNeighbourhoods& neighbourhoods,
                                 std::vector<double>& predicted) const {
  const auto& reach = neighbourhoods.reach(k, settings_.prediction_links);
  const double total = rowTotal(neighbourhoods.countByDepth());
  const double share = 1.0 - settings_.location_to_new_place;
  for (const auto& [position, links] : reach) {
    predicted[position + 1] += mass * (share * weightAt(links) / total);
  }
}

double TransitionModel::newPlaceStays(std::size_t wm_size) const {
  return wm_size == 0 ? 1.0 : settings_.new_place_stays;
}

double TransitionModel::newPlaceToEachLocation(std::size_t wm_size) const {
  return wm_size == 0 ? 0.0 : (1.0 - settings_.new_place_stays) / static_cast<double>(wm_size);
}

}  // namespace placedb
