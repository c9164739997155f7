// Which location a frame's loop-closure hypothesis names, and whether it survives the epipolar
// check. The Bayes filter's best location is often a link or two away from the best-matching
// one (its prediction smears mass along the path), so its WM neighbours compete with it.
#include <algorithm>
#include <set>

#include "engine/map_impl.h"
#include "engine/option_mapping.h"

namespace placedb {
namespace {

double similarityOf(const std::vector<LocationSimilarity>& similarities, LocationId id) {
  for (const auto& s : similarities)
    if (s.location == id) return s.similarity;
  return 0.0;
}

}  // namespace

GeometricView MapImpl::viewOf(std::int64_t location_id,
                              const std::vector<storage::WordRef>& refs) const {
  GeometricView view;
  // The location's own descriptors when it has them (three times the matches of word
  // descriptors on lip6_outdoor); maps made before they were kept fall back to its words'.
  if (auto bytes = store_->getState(keypointDescriptorsKey(location_id))) {
    view.descriptors = decodeDescriptors(*bytes, vocabulary_->dim());
    if (view.descriptors.rows == static_cast<int>(refs.size())) {
      for (const auto& ref : refs) view.points.emplace_back(ref.x, ref.y);
      return view;
    }
    view.descriptors.release();
  }
  view.points.reserve(refs.size());
  view.descriptors.create(static_cast<int>(refs.size()), vocabulary_->dim(), CV_32F);
  int row = 0;
  for (const auto& ref : refs) {
    const float* d = vocabulary_->descriptor(ref.word_id);
    if (!d) continue;  // every STM/WM word is in RAM; skip rather than trust a gap
    std::copy(d, d + vocabulary_->dim(), view.descriptors.ptr<float>(row++));
    view.points.emplace_back(ref.x, ref.y);
  }
  view.descriptors.resize(row);
  return view;
}

std::vector<LocationId> MapImpl::nearLastClosure(std::int64_t frame_id) const {
  // Without the geometric check there is no inlier count to relax.
  if (options_.temporal_min_inliers <= 0 || options_.geometry_min_inliers <= 0 ||
      counters_.last_closure_location == 0)
    return {};
  if (counters_.last_closure_session != *session_id_ ||
      frame_id - counters_.last_closure_frame > options_.temporal_max_gap)
    return {};
  std::vector<LocationId> near;
  const auto inWm = [this](LocationId id) {
    return tiers_->contains(id) && tiers_->tierOf(id) == Tier::kWm;
  };
  for (const auto& [id, depth] :
       graph_.withinLinks(counters_.last_closure_location, options_.temporal_radius, inWm))
    near.push_back(id);  // sorted by id
  return near;
}

MapImpl::Verified MapImpl::verifyHypothesis(const FilterOutcome& outcome, const Features& features,
                                            const std::vector<LocationSimilarity>& similarities,
                                            std::int64_t frame_id) {
  Verified v;
  v.location = outcome.hypothesis;
  if (outcome.hypothesis == kNewPlace) return v;

  // Breadth-first over WM only: STM locations are never loop candidates.
  std::vector<LocationId> candidates{outcome.hypothesis};
  std::set<LocationId> seen{outcome.hypothesis};
  std::size_t level_begin = 0;
  for (int depth = 0; depth < options_.hypothesis_radius; ++depth) {
    const std::size_t level_end = candidates.size();
    for (std::size_t k = level_begin; k < level_end; ++k) {
      for (LocationId n : graph_.neighbourSet(candidates[k])) {
        if (!seen.insert(n).second) continue;
        if (tiers_->contains(n) && tiers_->tierOf(n) == Tier::kWm) candidates.push_back(n);
      }
    }
    level_begin = level_end;
  }

  // The most similar WM locations compete too: after a long detour the filter's mass can sit a
  // few locations away from the revisited place, where no neighbourhood reaches.
  if (options_.hypothesis_top_similar > 0) {
    std::vector<LocationSimilarity> top = similarities;
    const auto k = std::min(top.size(), static_cast<std::size_t>(options_.hypothesis_top_similar));
    std::partial_sort(top.begin(), top.begin() + static_cast<std::ptrdiff_t>(k), top.end(),
                      [](const LocationSimilarity& a, const LocationSimilarity& b) {
                        return a.similarity != b.similarity ? a.similarity > b.similarity
                                                            : a.location < b.location;
                      });
    for (std::size_t i = 0; i < k; ++i)
      if (seen.insert(top[i].location).second) candidates.push_back(top[i].location);
  }

  // The neighbourhood of the last accepted closure competes too: after a detour of the filter
  // the revisit usually goes on where the previous frame's closure was.
  const std::vector<LocationId> near = nearLastClosure(frame_id);
  for (LocationId n : near)
    if (seen.insert(n).second) candidates.push_back(n);

  const GeometricCheckSettings geometry = toGeometricCheckSettings(options_);
  if (geometry.min_inliers <= 0) {
    // No check: the most similar candidate, the filter's own choice on ties.
    double best = -1.0;
    for (LocationId c : candidates) {
      const double s = similarityOf(similarities, c);
      if (s > best) {
        best = s;
        v.location = c;
      }
    }
    v.passed = true;
    return v;
  }

  GeometricView query;
  query.descriptors = features.descriptors;
  query.points.reserve(features.size());
  for (const auto& k : features.keypoints) query.points.emplace_back(k.x, k.y);
  const auto refs = store_->loadWordRefs(candidates);
  int best = -1, best_near = -1;
  LocationId near_location = kNewPlace;
  int near_matches = 0;
  for (LocationId c : candidates) {
    auto it = refs.find(c);
    if (it == refs.end()) continue;
    const GeometricResult g = checkGeometry(query, viewOf(c, it->second), geometry);
    if (g.inliers > best) {
      best = g.inliers;
      v.location = c;
      v.matches = g.matches;
    }
    if (g.inliers > best_near && std::binary_search(near.begin(), near.end(), c)) {
      best_near = g.inliers;
      near_location = c;
      near_matches = g.matches;
    }
  }
  v.inliers = std::max(best, 0);
  v.passed = v.inliers >= geometry.min_inliers;
  if (!v.passed && best_near >= options_.temporal_min_inliers && near_location != kNewPlace) {
    // Too few inliers for a place on its own, enough for one that continues the last closure.
    v.location = near_location;
    v.inliers = best_near;
    v.matches = near_matches;
    v.passed = true;
    v.temporal = true;
  }
  return v;
}

}  // namespace placedb
