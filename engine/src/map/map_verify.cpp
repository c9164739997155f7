// Which location a frame's loop-closure hypothesis names, and whether it survives the epipolar
// check. The Bayes filter's best location is often a link or two away from the best-matching
// one (its prediction smears mass along the path), so its WM neighbours compete with it.
#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <set>

#include "decision/candidate_choice.h"
#include "decision/closure_evidence.h"
#include "decision/way_here.h"
#include "features/feature_options.h"
#include "map/map_impl.h"
#include "map/option_mapping.h"
#include "map/paired_checks.h"

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
  std::optional<CachedKeypoints> kept = keypoint_cache_.takePositions(location_id);
  if (!kept) return keypoint_cache_.insert(location_id, loadKeypoints(location_id));
  loadKeypointCodes(location_id, *kept);
  return keypoint_cache_.insert(location_id, std::move(*kept));
}

CachedKeypoints MapImpl::loadKeypoints(std::int64_t location_id) const {
  CachedKeypoints entry = keypointPositions(store_->loadWordRefs(location_id));
  loadKeypointCodes(location_id, entry);
  return entry;
}

CachedKeypoints MapImpl::keypointPositions(const std::vector<storage::WordRef>& refs) {
  CachedKeypoints entry;
  entry.points.reserve(refs.size());
  entry.words.reserve(refs.size());
  for (const auto& ref : refs) {
    entry.points.emplace_back(ref.x, ref.y);
    entry.words.push_back(ref.word_id);
  }
  return entry;
}

void MapImpl::loadKeypointCodes(std::int64_t location_id, CachedKeypoints& entry) const {
  if (auto bytes = store_->getState(keypointDescriptorsKey(location_id)))
    entry.codes =
        std::make_shared<const DescriptorCodes>(storedDescriptorCodes(*bytes, vocabulary_->dim()));
}

std::optional<GeometricView> MapImpl::placeView(LocationId location) {
  const CachedKeypoints& keypoints = keypointsOf(location);
  if (keypoints.points.empty()) return std::nullopt;
  return viewOf(keypoints);
}

std::optional<GeometricView> MapImpl::latestView(LocationId location) const {
  if (!options_.geometry_latest_view) return std::nullopt;
  const auto bytes = store_->getState(latestViewKey(location));
  if (!bytes) return std::nullopt;
  const std::optional<LatestView> latest = decodeLatestView(*bytes, vocabulary_->dim());
  if (!latest || latest->keypoints.points.empty()) return std::nullopt;
  return viewOf(latest->keypoints);
}

std::optional<GeometricResult> MapImpl::bestViewComparison(LocationId location,
                                                           const GeometricView& query,
                                                           int at_least) {
  const GeometricCheckSettings compare = toGeometricCheckSettings(options_);
  std::optional<GeometricResult> best;
  if (const std::optional<GeometricView> view = placeView(location))
    best = compareGeometry(query, *view, compare, at_least);
  if (const std::optional<GeometricView> latest = latestView(location)) {
    const int beat = best ? std::max(at_least, best->inliers + 1) : at_least;
    GeometricResult g = compareGeometry(query, *latest, compare, beat);
    g.latest_view = true;
    if (!best || g.inliers > best->inliers) best = std::move(g);
  }
  return best;
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

std::vector<LocationId> MapImpl::continuingEvidence(std::int64_t frame_id) const {
  const ClosureEvidence& evidence = counters_.closure_evidence;
  if (!geometricCheckOn(options_) || options_.geometry_rule == GeometryRule::kInliers ||
      !continuesEvidence(evidence, frame_id, *session_id_))
    return {};
  std::vector<LocationId> reach;
  const auto inWm = [this](LocationId id) { return tiers_->isIn(id, Tier::kWm); };
  // Along the traversal, as a closure run: between two frames the matching place moves a link
  // or two either way.
  for (const auto& [id, depth] : graph_.withinLinks(evidence.location, options_.temporal_radius,
                                                    inWm, LinkWalk::kNeighbourLinksOnly))
    reach.push_back(id);
  std::sort(reach.begin(), reach.end());
  return reach;
}

double MapImpl::frameEvidence(const GeometricResult& g, int places) const {
  const double own = std::min(g.log10_nfa + std::log10(std::max(1, places)), kNoModel);
  return g.passed ? std::min(own, std::log10(options_.geometry_max_nfa)) : own;
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

std::optional<AgreeingPlace> MapImpl::agreeingPlace(LocationId accepted,
                                                    const GeometricView& query) {
  const auto inWm = [this](LocationId id) { return tiers_->isIn(id, Tier::kWm); };
  std::vector<LocationId> neighbours;
  for (const auto& [id, depth] :
       graph_.withinLinks(accepted, 1, inWm, LinkWalk::kNeighbourLinksOnly))
    neighbours.push_back(id);
  return mostAgreeingPlace(accepted, neighbours, [&](LocationId c, int at_least) {
    return bestViewComparison(c, query, at_least);
  });
}

SceneShare MapImpl::sceneOf(const GeometricResult& place, LocationId own_view,
                            const GeometricView& query) {
  const GeometricCheckSettings compare = toGeometricCheckSettings(options_);
  // The frame's previous view, or the one before it when that one shows too little of the
  // scene to measure it (a blurred or featureless frame).
  std::optional<GeometricResult> own;
  for (int back = 0; back < 2 && own_view; ++back, own_view = traversalPredecessor(own_view)) {
    const std::optional<GeometricView> view = placeView(own_view);
    if (!view) continue;
    own = compareGeometry(query, *view, compare);
    if (static_cast<int>(own->agreeing_query.size()) >= kMinPlanePairs) break;
  }
  return sceneShare(place, own ? &*own : nullptr, agreementDistance(compare, query.image_size));
}

std::vector<LocationId> MapImpl::wayHere(LocationId accepted, LocationId own_view,
                                         bool& reaches) const {
  const auto inWm = [this](LocationId id) { return tiers_->isIn(id, Tier::kWm); };
  std::set<LocationId> surroundings;
  for (const auto& [id, depth] : graph_.withinLinks(accepted, 1, inWm, LinkWalk::kAnyLink))
    surroundings.insert(id);
  std::vector<LocationId> way;
  LocationId l = own_view;
  for (; l && !surroundings.count(l); l = traversalPredecessor(l)) way.push_back(l);
  reaches = l != 0;
  return way;
}

std::optional<WayHereRefusal> MapImpl::judgeWayHere(LocationId accepted, LocationId own_view,
                                                    const GeometricView& query,
                                                    const Signature& signature,
                                                    double accepted_log10_nfa) {
  bool reaches = false;
  const std::vector<LocationId> way = wayHere(accepted, own_view, reaches);
  const GeometricCheckSettings compare = toGeometricCheckSettings(options_);
  // Each place of the way is asked once, and on its own (it is no candidate of the frame),
  // whether any model agrees beyond chance: the fit may stop at the first that does.
  GeometricCheckSettings beyond_chance = compare;
  beyond_chance.max_nfa = 1;
  // Both walks check ahead on another core (paired_checks.h): the frame's from its end of the
  // way, the place's from the other.
  const int threads = resolveThreadCount(options_.threads);
  const auto prepare = [this](LocationId id) { return placeView(id); };
  const auto agreement = [&](const GeometricView& view) {
    return checkGeometry(query, view, beyond_chance);
  };
  PairedChecks from_frame(way, threads, prepare, agreement);
  PairedChecks from_place(std::vector<LocationId>(way.rbegin(), way.rend()), threads, prepare,
                          agreement);
  std::map<std::size_t, bool> unrelated_at;
  bool place_side = false;
  const Unrelated unrelated = [&](std::size_t i) {
    if (auto it = unrelated_at.find(i); it != unrelated_at.end()) return it->second;
    const auto g = place_side ? from_place(way[i]) : from_frame(way[i]);
    return unrelated_at[i] = !g || g->log10_nfa > 0;
  };
  WayHereRefusal refusal;
  refusal.accepted_log10_nfa = accepted_log10_nfa;
  refusal.way = static_cast<int>(way.size());
  const std::size_t end = surroundingsEnd(way.size(), unrelated);
  if (end == way.size()) {
    if (!reaches) return std::nullopt;
    refusal.verdict = WayHereVerdict::kNeverLeft;
    return refusal;
  }
  place_side = true;
  const std::size_t begin =
      reaches ? placeSurroundingsBegin(way.size(), end, unrelated) : way.size() - 1;
  const bool ranked = options_.geometry_way_here_ranked;
  const std::set<LocationId> visits = ranked ? earlierVisitsOf(accepted) : std::set<LocationId>{};
  std::vector<LocationId> between;
  for (std::size_t i = end; i <= begin; ++i)
    if (!visits.count(way[i])) between.push_back(way[i]);
  const std::set<LocationId> among(between.begin(), between.end());
  const std::vector<LocationId> impostors = mostSimilar(
      between, index_.similarities(signature, [&among](LocationId id) { return among.count(id); }),
      options_.geometry_way_here_checks);
  PairedChecks compared(impostors, threads, prepare, [&](const GeometricView& view) {
    return compareGeometry(query, view, compare);
  });
  const int uniform = ranked ? 0 : static_cast<int>(impostors.size());
  for (std::size_t j = 0; j < impostors.size(); ++j) {
    std::optional<GeometricResult> g = compared(impostors[j]);
    const double tries = impostorTries(static_cast<int>(j) + 1, uniform);
    if (g && refutes(accepted_log10_nfa, g->log10_nfa, tries, options_.geometry_max_nfa, ranked)) {
      refusal.verdict = WayHereVerdict::kRepeated;
      refusal.location = impostors[j];
      refusal.result = std::move(*g);
      refusal.impostors = static_cast<int>(impostors.size());
      refusal.counted_log10_nfa = countedLog10Nfa(refusal.result.log10_nfa, tries);
      return refusal;
    }
  }
  return std::nullopt;
}

std::optional<WayHereRefusal> MapImpl::continuedRefutation(const std::array<LocationId, 2>& claimed,
                                                           std::int64_t frame_id,
                                                           double accepted_log10_nfa) const {
  const RefutedPlace& refuted = counters_.refuted;
  if (!options_.geometry_way_here_ranked ||
      !withinRefutation(refuted, frame_id, *session_id_, options_.temporal_max_gap))
    return std::nullopt;
  // The impostor found for that frame stands for this one: its level is the chance level this
  // frame's evidence must beat by the bar's factor (way_here.h).
  if (!refutes(accepted_log10_nfa, refuted.impostor, 1, options_.geometry_max_nfa, false))
    return std::nullopt;
  const auto inWm = [this](LocationId id) { return tiers_->isIn(id, Tier::kWm); };
  for (const auto& [id, depth] : graph_.withinLinks(refuted.location, options_.temporal_radius,
                                                    inWm, LinkWalk::kNeighbourLinksOnly)) {
    if (id != claimed[0] && id != claimed[1]) continue;
    WayHereRefusal refusal;
    refusal.verdict = WayHereVerdict::kContinued;
    refusal.location = refuted.location;
    refusal.accepted_log10_nfa = accepted_log10_nfa;
    refusal.frames_since = frame_id - refuted.frame;
    return refusal;
  }
  return std::nullopt;
}

std::set<LocationId> MapImpl::earlierVisitsOf(LocationId accepted) const {
  // The map's own word that places are this one: a loop closure between the place's stretch of
  // its traversal and another visit's, each stretch as far as a closure run's jitter reaches
  // (a visit's closures land on a place or two beside the one the frame names).
  const auto inWm = [this](LocationId id) { return tiers_->isIn(id, Tier::kWm); };
  const auto stretch = [&](LocationId id) {
    return graph_.withinLinks(id, options_.temporal_radius, inWm, LinkWalk::kNeighbourLinksOnly);
  };
  std::set<LocationId> joined;
  for (const auto& [id, depth] : stretch(accepted))
    for (LocationId n : graph_.neighbourSet(id))
      if (graph_.isLoopClosure(id, n)) joined.insert(n);
  std::set<LocationId> visits;
  for (LocationId n : joined)
    for (const auto& [v, depth] : stretch(n)) visits.insert(v);
  return visits;
}

MapImpl::Verified MapImpl::verifyHypothesis(const FilterOutcome& outcome, const Features& features,
                                            const Quantised& q,
                                            const std::vector<LocationSimilarity>& similarities,
                                            std::int64_t frame_id, LocationId own_view) {
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
  // The places that continue the last frame's evidence count when the frame checks them anyway:
  // checking them for their own sake would give every frame more chances to pass by chance.
  const std::vector<LocationId> continuing = continuingEvidence(frame_id);
  // Most likely first (candidate_choice.h says how the first pass ends the search).
  const std::vector<LocationId> candidates = orderCandidates(
      sources, [&similarities](LocationId c) { return similarityOf(similarities, c); });

  GeometricCheckSettings geometry = toGeometricCheckSettings(options_);
  if (options_.geometry_count_candidates)
    v.places = geometry.tests = std::max(1, static_cast<int>(candidates.size()));
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

  // Entries of locations that left working memory go; a candidate is always in WM, and the
  // frame's own previous view (scene_extent.h) in STM or WM. An entry holds what the file holds,
  // so one left behind changes no result, only memory: the whole-cache pass runs once the cache
  // holds more entries than STM and WM have locations, which keeps it that small.
  if (keypoint_cache_.size() + keypoint_cache_.positionsKept() >
      tiers_->wmSize() + tiers_->stm().size())
    keypoint_cache_.retainIf([this](LocationId id) {
      return tiers_->isIn(id, Tier::kWm) || tiers_->isIn(id, Tier::kStm);
    });

  GeometricView query;
  query.descriptors = features.descriptors;
  query.points.reserve(features.size());
  for (const auto& k : features.keypoints) query.points.emplace_back(k.x, k.y);
  query.words = q.word_of_feature;
  query.image_size = features.image_size;
  query.codes = std::make_shared<const DescriptorCodes>(
      quantiseDescriptors(features.descriptors, kQueryCodeLevels));
  std::map<LocationId, GeometricResult> checked_continuing;
  PairedChecks checks(
      candidates, resolveThreadCount(options_.threads),
      [this](LocationId c) { return placeView(c); },
      [&](const GeometricView& view) { return checkGeometry(query, view, geometry); });
  const CandidateChoice choice = chooseCandidate(
      candidates, near, geometry.rule,
      [&](LocationId c) {
        std::optional<GeometricResult> g = checks(c);
        if (g && std::binary_search(continuing.begin(), continuing.end(), c))
          checked_continuing[c] = *g;
        return g;
      },
      [this](const GeometricResult& g) { return passesNearLastClosure(g); });
  v.checked = choice.checked;
  if (!choice.result) return v;
  LocationId reported = choice.location;
  const GeometricResult* result = &*choice.result;
  v.passed = choice.passed;
  v.temporal = choice.temporal;
  const ClosureEvidence& before = counters_.closure_evidence;
  const auto alternativesOf = [&continuing](LocationId c) {
    return std::binary_search(continuing.begin(), continuing.end(), c)
               ? static_cast<int>(continuing.size())
               : 0;
  };
  v.evidence = addEvidence(before, reported, frame_id, *session_id_,
                           frameEvidence(*result, v.places), alternativesOf(reported));
  if (!choice.passed) {
    // No frame passes alone: the strongest run through a place that continues the last one.
    for (const auto& [c, g] : checked_continuing) {
      const ClosureEvidence run =
          addEvidence(before, c, frame_id, *session_id_, frameEvidence(g, v.places),
                      static_cast<int>(continuing.size()));
      if (run.log10_nfa < v.evidence.log10_nfa) {
        v.evidence = run;
        reported = c;
        result = &g;
      }
    }
    if (v.evidence.frames > 1 && v.evidence.log10_nfa <= std::log10(options_.geometry_max_nfa)) {
      v.passed = true;
      v.by_evidence = true;
    } else {
      reported = choice.location;  // the frame's own best, as before
      result = &*choice.result;
    }
  }
  // The place an accepted closure names: the accepted one or a traversal neighbour that agrees
  // with the frame on more pairs (agreeing_place.h). Its evidence stays the decision's.
  const LocationId accepted_place = reported;
  const bool in_run = std::binary_search(near.begin(), near.end(), accepted_place);
  std::optional<AgreeingPlace> agreeing;
  if (outcome.accepted && v.passed) agreeing = agreeingPlace(reported, query);
  if (agreeing && agreeing->location != reported) {
    reported = agreeing->location;
    result = &agreeing->result;
  }
  // A place that passed on its own must share the frame's scene, not one object of it. The
  // relaxed rule and runs of frames lean on a closure that did.
  if (v.passed && agreeing && !v.temporal && !v.by_evidence &&
      options_.geometry_min_scene_share > 0) {
    const SceneShare scene = sceneOf(agreeing->result, own_view, query);
    if (scene.measured && scene.share < options_.geometry_min_scene_share) {
      v.passed = false;
      v.object_only = scene;
      v.evidence = ClosureEvidence{};  // an object's agreement carries no run either
      v.ends_run = options_.temporal_end_on_object && in_run;
    }
  }
  // A closure that starts a run must be the place its agreement singles out (way_here.h); one
  // that continues the run (accepted within its reach, on the relaxed rule or not) leans on that
  // start, wherever the agreeing neighbour then names it.
  if (v.passed && agreeing && !v.temporal && options_.geometry_way_here_checks > 0 &&
      options_.geometry_rule != GeometryRule::kInliers && !in_run) {
    v.way_here = continuedRefutation({accepted_place, reported}, frame_id, v.evidence.log10_nfa);
    if (!v.way_here)
      v.way_here = judgeWayHere(reported, own_view, query, q.signature, v.evidence.log10_nfa);
    if (v.way_here) {
      v.passed = false;
      v.evidence = ClosureEvidence{};  // a pattern's agreement carries no run either
    }
  }
  v.location = reported;
  v.geometry = *result;
  if (v.passed && outcome.accepted && result->latest_view && options_.hasIntrinsics())
    if (const std::optional<GeometricView> view = placeView(reported))
      v.pose_geometry = compareGeometry(query, *view, toGeometricCheckSettings(options_));
  v.continues_run = std::binary_search(near.begin(), near.end(), reported);
  v.inliers = result->inliers;
  v.matches = result->matches;
  // Counted over the places the frame chose among, as its acceptance was.
  v.log10_nfa = std::min(result->log10_nfa + std::log10(v.places), kNoModel);
  return v;
}

}  // namespace placedb
