// Which location a frame's loop-closure hypothesis names, and whether it survives the epipolar
// check. The Bayes filter's best location is often a link or two away from the best-matching
// one (its prediction smears mass along the path), so its WM neighbours compete with it.
#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <set>

#include "decision/candidate_choice.h"
#include "map/map_impl.h"
#include "map/option_mapping.h"

namespace placedb {
namespace {

// Reported for a fit that found no model beyond its 7-pair sample.
constexpr double kNoModel = 99.0;

double similarityOf(const std::vector<LocationSimilarity>& similarities, LocationId id) {
  for (const auto& s : similarities)
    if (s.location == id) return s.similarity;
  return 0.0;
}

}  // namespace

const CachedKeypoints& MapImpl::keypointsOf(std::int64_t location_id) {
  if (const CachedKeypoints* hit = keypoint_cache_.find(location_id)) return *hit;
  return keypoint_cache_.insert(location_id, loadKeypoints(location_id));
}

CachedKeypoints MapImpl::loadKeypoints(std::int64_t location_id) const {
  CachedKeypoints entry;
  for (const auto& ref : store_->loadWordRefs(location_id)) {
    entry.points.emplace_back(ref.x, ref.y);
    entry.words.push_back(ref.word_id);
  }
  if (auto bytes = store_->getState(keypointDescriptorsKey(location_id)))
    entry.codes =
        std::make_shared<const DescriptorCodes>(storedDescriptorCodes(*bytes, vocabulary_->dim()));
  return entry;
}

GeometricView MapImpl::viewOf(const CachedKeypoints& keypoints) const {
  GeometricView view;
  view.points = keypoints.points;
  view.words = keypoints.words;
  // The location's own descriptors when it has them (three times the matches of word
  // descriptors on lip6_outdoor); maps made before they were kept fall back to its words'.
  // They stay codes: the matcher decodes the rows it compares in full.
  if (keypoints.codes && keypoints.codes->rows == static_cast<int>(keypoints.points.size()) &&
      keypoints.codes->rows > 0) {
    view.codes = keypoints.codes;
    return view;
  }
  view.points.clear();
  view.words.clear();
  view.descriptors.create(static_cast<int>(keypoints.points.size()), vocabulary_->dim(), CV_32F);
  int row = 0;
  for (std::size_t i = 0; i < keypoints.points.size(); ++i) {
    const float* d = vocabulary_->descriptor(keypoints.words[i]);
    if (!d) continue;  // every STM/WM word is in RAM; skip rather than trust a gap
    std::copy(d, d + vocabulary_->dim(), view.descriptors.ptr<float>(row++));
    view.points.push_back(keypoints.points[i]);
    view.words.push_back(keypoints.words[i]);
  }
  view.descriptors.resize(row);
  return view;
}

bool MapImpl::passesNearLastClosure(const GeometricResult& g) const {
  const bool by_count = options_.geometry_rule != GeometryRule::kNfa &&
                        options_.temporal_min_inliers > 0 &&
                        g.inliers >= options_.temporal_min_inliers;
  const bool by_chance = options_.geometry_rule != GeometryRule::kInliers &&
                         options_.temporal_max_nfa > 0 &&
                         g.log10_nfa <= std::log10(options_.temporal_max_nfa) &&
                         g.inliers >= minimumInliers(options_.temporal_min_overlap, g.keypoints);
  return by_count || by_chance;
}

std::vector<LocationId> MapImpl::nearLastClosure(std::int64_t frame_id) const {
  // Without the geometric check there is no chance level to relax.
  const bool relaxed =
      (options_.geometry_rule != GeometryRule::kNfa && options_.temporal_min_inliers > 0) ||
      (options_.geometry_rule != GeometryRule::kInliers && options_.temporal_max_nfa > 0);
  if (!relaxed || !geometricCheckOn(options_)) return {};
  const ClosureRun& run = counters_.closure_run;
  const std::optional<RunReach> reach =
      reachOf(run, frame_id, *session_id_, toRunSettings(options_));
  if (!reach) return {};
  std::vector<LocationId> near;
  const auto inWm = [this](LocationId id) { return tiers_->isIn(id, Tier::kWm); };
  // Along the traversal only: through a loop-closure link the walk would reach another visit of
  // the place, whose offset from this one adds to the closure's own.
  for (const auto& [id, depth] :
       graph_.withinLinks(run.anchor, reach->links, inWm, LinkWalk::kNeighbourLinksOnly))
    if (reach->admits(run.anchor, id)) near.push_back(id);  // sorted by id
  return near;
}

MapImpl::Verified MapImpl::verifyHypothesis(const FilterOutcome& outcome, const Features& features,
                                            const std::vector<std::int64_t>& word_of_feature,
                                            const std::vector<LocationSimilarity>& similarities,
                                            std::int64_t frame_id) {
  Verified v;
  v.location = outcome.hypothesis;
  if (outcome.hypothesis == kNewPlace) return v;

  CandidateSources sources;
  sources.hypothesis = outcome.hypothesis;
  // Breadth-first over WM only: STM locations are never loop candidates.
  const auto inWm = [this](LocationId id) { return tiers_->isIn(id, Tier::kWm); };
  std::set<LocationId> reached{outcome.hypothesis};
  std::vector<LocationId> level{outcome.hypothesis};
  for (int depth = 0; depth < options_.hypothesis_radius; ++depth) {
    std::vector<LocationId> next;
    for (LocationId c : level)
      for (LocationId n : graph_.neighbourSet(c))
        if (reached.insert(n).second && inWm(n)) next.push_back(n);
    sources.around.insert(sources.around.end(), next.begin(), next.end());
    level = std::move(next);
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
    for (std::size_t i = 0; i < k; ++i) sources.most_similar.push_back(top[i].location);
  }
  for (LocationId c : searched_back_)
    if (inWm(c)) sources.searched_back.push_back(c);
  // After a detour of the filter the revisit usually goes on where the previous frame's
  // closure was.
  sources.near_last_closure = nearLastClosure(frame_id);
  const std::vector<LocationId>& near = sources.near_last_closure;
  // Most likely first (candidate_choice.h says how the first pass ends the search).
  const std::vector<LocationId> candidates = orderCandidates(
      sources, [&similarities](LocationId c) { return similarityOf(similarities, c); });

  const GeometricCheckSettings geometry = toGeometricCheckSettings(options_);
  if (!geometricCheckOn(options_)) {
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

  // Entries of locations that left working memory go; a candidate is always in WM.
  keypoint_cache_.retainIf([this](LocationId id) { return tiers_->isIn(id, Tier::kWm); });

  GeometricView query;
  query.descriptors = features.descriptors;
  query.points.reserve(features.size());
  for (const auto& k : features.keypoints) query.points.emplace_back(k.x, k.y);
  query.words = word_of_feature;
  query.codes = std::make_shared<const DescriptorCodes>(
      quantiseDescriptors(features.descriptors, kQueryCodeLevels));
  const CandidateChoice choice = chooseCandidate(
      candidates, near, geometry.rule,
      [&](LocationId c) -> std::optional<GeometricResult> {
        const CachedKeypoints& keypoints = keypointsOf(c);
        if (keypoints.points.empty()) return std::nullopt;
        return checkGeometry(query, viewOf(keypoints), geometry);
      },
      [this](const GeometricResult& g) { return passesNearLastClosure(g); });
  v.checked = choice.checked;
  if (choice.result) {
    v.location = choice.location;
    v.geometry = *choice.result;
    v.passed = choice.passed;
    v.temporal = choice.temporal;
    v.continues_run = std::binary_search(near.begin(), near.end(), choice.location);
    v.inliers = choice.result->inliers;
    v.matches = choice.result->matches;
    v.log10_nfa = std::min(choice.result->log10_nfa, kNoModel);
  }
  return v;
}

}  // namespace placedb
