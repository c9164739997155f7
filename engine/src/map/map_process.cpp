// One frame through the pipeline: features, quantisation, STM, likelihood, filter, memory
// management, and one transaction that commits everything the frame changed.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <set>

#include "features/image_conversion.h"
#include "map/map_impl.h"
#include "map/map_structure.h"
#include "map/option_mapping.h"

namespace placedb {
namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

storage::LinkRecord link(std::int64_t a, std::int64_t b, storage::LinkType type,
                         std::optional<double> score = std::nullopt) {
  return {std::min(a, b), std::max(a, b), type, score};
}

}  // namespace

struct MapImpl::FrameWrite {
  storage::FrameRecord frame;
  std::optional<storage::LocationRecord> new_location;
  std::vector<storage::WordRef> refs;              // the new location's signature
  std::vector<std::uint8_t> keypoint_descriptors;  // the same keypoints' own descriptors
  std::vector<std::uint8_t> latest_view;  // a merged frame's, for its location (latest_view.h)
  std::vector<storage::WordRecord> words;
  std::vector<storage::LinkRecord> links;
  std::optional<std::pair<std::int64_t, std::int64_t>> weight;  // location, new weight
  std::vector<std::int64_t> to_wm, to_ltm;
  std::optional<storage::HypothesisRecord> hypothesis;
  std::optional<std::vector<std::int8_t>> place_code;              // the new location's
  std::optional<storage::LocationWordDescriptors> location_words;  // the new location's
  std::vector<std::uint8_t> place_coder;                           // the centres, once per map
  std::vector<std::pair<std::int64_t, std::int64_t>> ages;         // locations entering STM/WM
  // The hypothesis whose frames the result names, read in the frame's transaction: once the
  // commit returns, the frame needs nothing more from the map, so a lost connection or a kill
  // after it cannot separate a committed frame from its result.
  std::optional<std::int64_t> frames_of;
};

FrameResult MapImpl::process(const cv::Mat& image, std::int64_t source_index,
                             const std::string& source_path, std::optional<std::int64_t> stamp_ns) {
  requireSession("process");
  frame_stamp_ns_ = stamp_ns;
  const auto start = Clock::now();
  cv::Mat grey;
  try {
    grey = toGrey8(image);
  } catch (const Error& e) {
    if (e.code() != ErrorCode::kInvalidArgument) throw;
    StageTimes times;
    times.features = times.total = msSince(start);
    return abandonOnError(
        [&] { return recordBad(source_index, source_path, 0, times); });  // nothing to see
  }
  Features features = extractor_->extract(grey);
  return abandonOnError(
      [&] { return processFeatures(features, source_index, source_path, msSince(start)); });
}

FrameResult MapImpl::recordUnreadable(std::int64_t source_index, const std::string& source_path,
                                      std::optional<std::int64_t> stamp_ns) {
  requireSession("recordUnreadable");
  frame_stamp_ns_ = stamp_ns;
  return abandonOnError([&] { return recordBad(source_index, source_path, 0, StageTimes()); });
}

FrameResult MapImpl::abandonOnError(const std::function<FrameResult()>& frame) {
  try {
    return frame();
  } catch (...) {
    // Ids reserved for the frame (map_fleet.cpp) went back with its transaction: RAM is ahead.
    if (frame_tx_) {
      frame_tx_.reset();
      broken_ = true;
    }
    throw;
  }
}

FrameResult MapImpl::recordBad(std::int64_t source_index, const std::string& source_path,
                               std::size_t feature_count, const StageTimes& times) {
  reserveIds(0);
  FrameResult r;
  r.frame_id = counters_.next_frame_id++;
  r.session_id = *session_id_;
  r.source_index = source_index;
  r.outcome = FrameOutcome::kBad;
  r.feature_count = feature_count;
  r.times = times;
  r.hypothesis.rejected_reason = "bad frame";
  FrameWrite w;
  w.frame.id = r.frame_id;
  w.frame.outcome = storage::FrameOutcome::kBad;
  commit(w, r, source_path);
  return r;
}

FrameResult MapImpl::processFeatures(const Features& features, std::int64_t source_index,
                                     const std::string& source_path, double features_ms) {
  const auto start = Clock::now() - std::chrono::duration_cast<Clock::duration>(
                                        std::chrono::duration<double, std::milli>(features_ms));
  StageTimes times;
  times.features = features_ms;
  const double mean_features =
      counters_.feature_frames ? double(counters_.feature_sum) / counters_.feature_frames : 0.0;
  if (features.size() == 0 || double(features.size()) < options_.bad_ratio * mean_features) {
    times.total = msSince(start);
    return recordBad(source_index, source_path, features.size(), times);
  }
  reserveIds(vocabulary_->options().fixed ? 0 : static_cast<std::int64_t>(features.size()));
  learnOtherWritersPlaces();
  counters_.feature_sum += static_cast<std::int64_t>(features.size());
  counters_.feature_frames += 1;

  tiers_->beginFrame();
  frame_code_.reset();
  searched_back_.clear();
  read_ahead_places_.clear();
  FrameResult r;
  FrameWrite w;
  r.frame_id = counters_.next_frame_id++;
  r.session_id = *session_id_;
  r.source_index = source_index;
  r.feature_count = features.size();
  w.frame.id = r.frame_id;

  auto stage = Clock::now();
  const Quantised q = quantise(features, r, w);
  times.quantisation = msSince(stage);

  placeInShortTermMemory(features, q, r, w);
  stage = Clock::now();
  searchLongTermMemory(features, w, r);
  const double search_ms = msSince(stage);

  stage = Clock::now();
  auto similarities = index_.similarities(
      q.signature, [this](LocationId id) { return tiers_->tierOf(id) == Tier::kWm; });
  times.likelihood = msSince(stage);

  stage = Clock::now();
  FilterOutcome outcome = filter_->update(tiers_->wm(), similarities, graph_);
  counters_.previous_score = filter_->state().previous_score;
  const double update_ms = msSince(stage);
  const std::int64_t hypothesis =
      decideLoopClosure(outcome, features, q, similarities, r, w, times);
  times.filter = msSince(stage);

  stage = Clock::now();
  // The time budget counts only the stages whose cost grows with memory.
  manageMemory(hypothesis, search_ms + times.likelihood + update_ms, w, r);
  times.memory = search_ms + msSince(stage);

  r.times = times;
  if (hypothesis != kNewPlace) w.frames_of = hypothesis;
  commit(w, r, source_path);
  readAhead(hypothesis);
  return r;
}

MapImpl::Quantised MapImpl::quantise(const Features& features, FrameResult& r, FrameWrite& w) {
  Quantised out;
  // Every feature gets a word; new words enter the index at once.
  vocab::Quantization q = vocabulary_->quantize(features.descriptors, r.frame_id);
  for (std::int64_t id : q.created_words)
    w.words.push_back(storage::WordRecord::fromFloats(id, r.frame_id, vocabulary_->descriptor(id),
                                                      vocabulary_->dim()));
  std::vector<WordId> word_ids;
  word_ids.reserve(q.word_of_feature.size());
  for (std::int64_t id : q.word_of_feature)
    if (id >= 0) word_ids.push_back(id);
  out.signature = Signature::fromWords(word_ids);
  r.words_created = q.created_words.size();
  r.mean_quantisation_error = q.mean_error;
  out.created_words = std::move(q.created_words);
  out.word_of_feature = std::move(q.word_of_feature);
  return out;
}

void MapImpl::placeInShortTermMemory(const Features& features, const Quantised& q, FrameResult& r,
                                     FrameWrite& w) {
  // Merge into the newest location when similar enough, else a new location.
  std::int64_t previous = counters_.last_session == *session_id_ ? counters_.last_location : 0;
  bool previous_live =
      previous && tiers_->contains(previous) && tiers_->tierOf(previous) != Tier::kLtm;
  if (previous_live && tiers_->tierOf(previous) == Tier::kStm &&
      similarity(q.signature, index_.signatureOf(previous)) > options_.t_sim) {
    r.outcome = FrameOutcome::kMerged;
    r.location_id = previous;
    tiers_->addWeight(previous, 1);
    w.weight = {previous, tiers_->weightOf(previous)};
    // The merged frame's own new words are referenced by no location: they leave the index.
    vocabulary_->erase(q.created_words);
    if (options_.geometry_latest_view && geometricCheckOn(options_) &&
        features.descriptors.type() == CV_32F)
      w.latest_view = latestViewOf(features, q, r.frame_id);
  } else {
    r.outcome = FrameOutcome::kNewLocation;
    r.location_id = counters_.next_location_id++;
    index_.add(r.location_id, q.signature);
    graph_.addNode(r.location_id);
    if (previous_live) {
      graph_.addLink(previous, r.location_id);
      w.links.push_back(link(previous, r.location_id, storage::LinkType::kNeighbour));
    }
    w.new_location =
        storage::LocationRecord{r.location_id, *session_id_, 0, storage::Tier::kStm, r.frame_id};
    const cv::Mat kept = quantisedKeypoints(features, q, w.refs);
    if (geometricCheckOn(options_) && features.descriptors.type() == CV_32F)
      w.keypoint_descriptors = encodeDescriptors(kept);
    storeLocationWords(r.location_id, q.signature, w);
    storePlaceCode(r.location_id, features, w);
    const auto overflow = tiers_->push(r.location_id);
    w.ages.emplace_back(r.location_id, tiers_->ageOf(r.location_id));
    enterWorkingMemory(overflow, w);
    counters_.last_location = r.location_id;
    counters_.last_session = *session_id_;
  }
  w.frame.outcome = r.outcome == FrameOutcome::kMerged ? storage::FrameOutcome::kMerged
                                                       : storage::FrameOutcome::kNewLocation;
  w.frame.location_id = r.location_id;
}

cv::Mat MapImpl::quantisedKeypoints(const Features& features, const Quantised& q,
                                    std::vector<storage::WordRef>& refs) {
  refs.reserve(features.size());
  cv::Mat kept;
  for (std::size_t i = 0; i < features.size(); ++i) {
    if (q.word_of_feature[i] < 0) continue;
    const Keypoint& k = features.keypoints[i];
    refs.push_back({q.word_of_feature[i], k.x, k.y, k.size, k.angle, k.response});
    kept.push_back(features.descriptors.row(static_cast<int>(i)));
  }
  return kept;
}

std::vector<std::uint8_t> MapImpl::latestViewOf(const Features& features, const Quantised& q,
                                                std::int64_t frame_id) {
  std::vector<storage::WordRef> refs;
  const cv::Mat kept = quantisedKeypoints(features, q, refs);
  std::vector<std::int64_t> discarded = q.created_words;
  std::sort(discarded.begin(), discarded.end());
  std::vector<cv::Point2f> points;
  std::vector<std::int64_t> words;
  for (const auto& ref : refs) {
    points.emplace_back(ref.x, ref.y);
    // A word the merge erased matches no other view's; its keypoint still matches by descriptor.
    const bool gone = std::binary_search(discarded.begin(), discarded.end(), ref.word_id);
    words.push_back(gone ? -1 : ref.word_id);
  }
  return encodeLatestView(frame_id, points, words, encodeDescriptors(kept));
}

std::string MapImpl::rejectionOf(const FilterOutcome& outcome, const Verified& verified) {
  if (verified.object_only)
    return fmt::format(
        "scene: {} inliers of {} matches cover {:.0f} % of the frame's scene (an object, not "
        "the place)",
        verified.inliers, verified.matches, 100 * verified.object_only->share);
  if (verified.way_here && verified.way_here->verdict == WayHereVerdict::kNeverLeft)
    return fmt::format(
        "way here: no two places in a row of the {} on the frame's way back to the place are "
        "unrelated to it (one scene all along, not a revisit)",
        verified.way_here->way);
  if (verified.way_here && verified.way_here->verdict == WayHereVerdict::kContinued)
    return fmt::format(
        "way here: location {} was refused as a pattern that repeats along the route {} "
        "frame(s) before, and the frame claims it or a neighbour again (the same agreement, not "
        "the place)",
        verified.way_here->location, verified.way_here->frames_since);
  if (verified.way_here)
    return fmt::format(
        "way here: location {} of the frame's way here agrees with NFA 1e{:.1f} (1e{:.1f} "
        "counted among {} compared) against the closure's 1e{:.1f} (a pattern that repeats "
        "along the route, not the place)",
        verified.way_here->location, verified.way_here->result.log10_nfa,
        verified.way_here->counted_log10_nfa, verified.way_here->impostors,
        verified.way_here->accepted_log10_nfa);
  if (verified.passed) return toString(outcome.reason);
  const std::string over =
      verified.places > 1 ? fmt::format(" over {} places", verified.places) : std::string();
  return fmt::format("geometry: {} inliers of {} matches, NFA 1e{:.1f}{}", verified.inliers,
                     verified.matches, verified.log10_nfa, over);
}

LocationId MapImpl::ownViewOf(const FrameResult& r) const {
  return r.outcome == FrameOutcome::kMerged ? r.location_id : traversalPredecessor(r.location_id);
}

LocationId MapImpl::traversalPredecessor(LocationId location) const {
  // A new location is linked to the one before it when that one was live (STM or WM).
  LocationId previous = 0;
  for (LocationId n : graph_.neighbourSet(location))
    if (n < location && !graph_.isLoopClosure(n, location)) previous = std::max(previous, n);
  return previous;
}

std::int64_t MapImpl::decideLoopClosure(const FilterOutcome& outcome, const Features& features,
                                        const Quantised& q,
                                        const std::vector<LocationSimilarity>& similarities,
                                        FrameResult& r, FrameWrite& w, StageTimes& times) {
  // The reported hypothesis is chosen among the filter's best and its competitors by the
  // geometric check.
  const auto verify_start = Clock::now();
  const Verified verified =
      verifyHypothesis(outcome, features, q, similarities, frameClock(r.frame_id), ownViewOf(r));
  // Measuring the pose is part of verification; it never changes the decision.
  std::optional<storage::ClosurePose> pose;
  if (options_.hasIntrinsics() && verified.location != kNewPlace && outcome.accepted &&
      verified.passed)
    pose = closurePose(verified.location,
                       verified.pose_geometry ? *verified.pose_geometry : verified.geometry);
  times.verification = msSince(verify_start);
  r.hypothesis.candidates_checked = verified.checked;
  counters_.closure_evidence = verified.evidence;
  if (verified.ends_run) counters_.closure_run = ClosureRun{};
  // Only a refutation measured on the frame's own way anchors the next frames' (way_here.h):
  // carried on from frame to frame it would follow a revisit along the graph.
  if (verified.way_here && verified.way_here->verdict == WayHereVerdict::kRepeated)
    counters_.refuted = {verified.location, frameClock(r.frame_id), r.session_id,
                         verified.way_here->counted_log10_nfa};
  r.hypothesis.evidence_frames = verified.by_evidence   ? verified.evidence.frames
                                 : verified.checked > 0 ? 1
                                                        : 0;
  const std::int64_t hypothesis = verified.location;
  std::string reason;
  if (hypothesis != kNewPlace) {
    r.hypothesis.location_id = hypothesis;
    r.hypothesis.posterior = filter_->posteriorOf(hypothesis);
    r.hypothesis.inliers = verified.inliers;
    r.hypothesis.matches = verified.matches;
    r.hypothesis.log10_nfa = verified.log10_nfa;
    r.hypothesis.accepted = outcome.accepted && verified.passed;
    // EVALUATION.md: the score is 0 where a check other than the final threshold rejected it.
    const bool vetoed = !verified.passed || outcome.reason == RejectReason::kRatioTest;
    r.hypothesis.score = vetoed ? 0.0 : outcome.score;
    if (r.hypothesis.accepted) {
      r.hypothesis.pose = pose;
      acceptLoopClosure(hypothesis, verified, r, w);
    }
    if (!r.hypothesis.accepted) reason = rejectionOf(outcome, verified);
  } else {
    reason = toString(outcome.reason);
  }
  r.hypothesis.rejected_reason = reason;
  storage::HypothesisRecord record;
  record.frame_id = r.frame_id;
  if (hypothesis != kNewPlace) record.best_location_id = hypothesis;
  record.posterior = r.hypothesis.posterior;
  record.loop_probability = r.hypothesis.score;
  record.accepted = r.hypothesis.accepted;
  record.rejected_reason = reason;
  record.pose = r.hypothesis.pose;
  w.hypothesis = record;
  return hypothesis;
}

void MapImpl::acceptLoopClosure(std::int64_t hypothesis, const Verified& verified, FrameResult& r,
                                FrameWrite& w) {
  // Only a closure that passed on its own anchors the next ones: chains of temporal
  // acceptances would drift along the graph while the camera moves on.
  if (!verified.temporal)
    counters_.closure_run = anchorAt(counters_.closure_run, hypothesis, frameClock(r.frame_id),
                                     r.session_id, verified.continues_run, toRunSettings(options_));
  if (hypothesis != r.location_id) {
    w.links.push_back(
        link(r.location_id, hypothesis, storage::LinkType::kLoopClosure, r.hypothesis.score));
    graph_.addLink(r.location_id, hypothesis, LinkKind::kLoopClosure);
  }
}

std::optional<storage::ClosurePose> MapImpl::closurePose(std::int64_t hypothesis,
                                                         const GeometricResult& geometry,
                                                         std::string* why) {
  const auto none = [why](std::string reason) -> std::optional<storage::ClosurePose> {
    if (why) *why = std::move(reason);
    return std::nullopt;
  };
  const auto location = store_->location(hypothesis);
  if (!location) return none(fmt::format("location {} is not stored", hypothesis));
  const CameraIntrinsics ours = intrinsicsOf(options_);
  const CameraIntrinsics theirs = sessionIntrinsics(location->session_id);
  const char* no_camera = "no camera intrinsics: the map's settings fx fy cx cy are 0";
  if (!theirs.known())
    return none(ours.known() ? fmt::format("session {}, which mapped location {}, has no "
                                           "camera intrinsics",
                                           location->session_id, hypothesis)
                             : no_camera);
  if (geometry.still) {
    // The pairs did not move: no rotation, and no translation to give a direction to.
    if (geometry.agreeing_query.empty()) return none("no agreeing pair to measure it on");
    storage::ClosurePose pose;
    pose.inliers = static_cast<std::int64_t>(geometry.agreeing_query.size());
    return pose;
  }
  if (!ours.known()) return none(no_camera);
  RelativePoseSettings settings;
  settings.max_error_px = options_.geometry_max_error_px;
  auto pose =
      relativePose(geometry.agreeing_query, ours, geometry.agreeing_candidate, theirs, settings);
  const std::size_t pairs = geometry.agreeing_query.size();
  if (!pose && pairs < 5)
    return none(fmt::format("{} agreeing pairs: an essential matrix needs 5", pairs));
  if (!pose)
    return none(
        fmt::format("no essential matrix puts {} of the {} agreeing pairs in front of "
                    "both cameras",
                    settings.min_inliers, pairs));
  return pose;
}

CameraIntrinsics MapImpl::sessionIntrinsics(std::int64_t session_id) {
  if (session_id_ && session_id == *session_id_) return intrinsicsOf(options_);
  if (auto known = session_intrinsics_.find(session_id); known != session_intrinsics_.end())
    return known->second;
  // Another session's camera, as it was set when that session began.
  CameraIntrinsics camera;
  try {
    camera = intrinsicsOf(Options::fromStoredSettings(store_->settings(session_id)));
  } catch (const Error&) {
    // Settings this binary cannot read: no camera, so no pose (the decision stands).
  }
  session_intrinsics_[session_id] = camera;
  return camera;
}

void MapImpl::manageMemory(std::int64_t hypothesis, double memory_ms, FrameWrite& w,
                           FrameResult& r) {
  // Bring back the hypothesis' LTM neighbours, then bound WM.
  const auto start = Clock::now();
  if (hypothesis != kNewPlace) retrieveNeighbours(hypothesis, w, r);
  transferToLtm(hypothesis, (memory_ms + msSince(start)) / 1000.0, w, r);
}

void MapImpl::enterWorkingMemory(const std::vector<std::int64_t>& ids, FrameWrite& write) {
  write.to_wm.insert(write.to_wm.end(), ids.begin(), ids.end());
}

void MapImpl::retrieveNeighbours(std::int64_t hypothesis, FrameWrite& write, FrameResult& result) {
  if (options_.max_retrieved <= 0 || tiers_->ltmSize() == 0) return;
  // Nearest first: the hypothesis' own LTM links, then those of its live neighbours.
  std::vector<std::int64_t> candidates = store_->linkedInTier(hypothesis, storage::Tier::kLtm);
  for (std::int64_t n : graph_.neighbours(hypothesis)) {
    if (candidates.size() >= static_cast<std::size_t>(options_.max_retrieved)) break;
    auto more = store_->linkedInTier(n, storage::Tier::kLtm);
    candidates.insert(candidates.end(), more.begin(), more.end());
  }
  bringBack(tiers_->retrievalCandidates(hypothesis, candidates), write, result);
}

void MapImpl::searchLongTermMemory(const Features& features, FrameWrite& write,
                                   FrameResult& result) {
  if (options_.ltm_search <= 0 || tiers_->ltmSize() == 0 || !coder_) return;
  // The places most like this frame among WM and LTM; those in LTM come back before the
  // likelihood, so the filter and the check see them in this very frame.
  const auto code = frameCode(features);
  const auto wanted = static_cast<std::size_t>(options_.ltm_search);
  // Reading ahead, the search ranks twice as many again: the places just below the cut are the
  // likeliest to make it at the next frame. The first ltm_search are the same either way.
  const std::size_t ranked = options_.read_ahead_links > 0 ? 3 * wanted : wanted;
  const auto matches = places_.search(code, ranked, [this](LocationId id) {
    return tiers_->contains(id) && tiers_->tierOf(id) != Tier::kStm;
  });
  std::vector<std::int64_t> ids;
  for (std::size_t i = 0; i < matches.size(); ++i) {
    if (ranked > wanted) read_ahead_places_.push_back(matches[i].location);
    if (i < wanted && tiers_->tierOf(matches[i].location) == Tier::kLtm)
      ids.push_back(matches[i].location);
  }
  bringBack(ids, write, result);
  result.retrieved_by_search = ids.size();
  searched_back_ = std::move(ids);  // loop candidates of this frame (candidate_choice.h)
}

void MapImpl::restoreWords(std::vector<std::int64_t> missing,
                           const std::vector<std::int64_t>& locations) {
  std::sort(missing.begin(), missing.end());
  missing.erase(std::unique(missing.begin(), missing.end()), missing.end());
  if (missing.empty()) return;
  cv::Mat descriptors(static_cast<int>(missing.size()), vocabulary_->dim(), CV_32F);
  std::vector<std::int64_t> created(missing.size());
  store_->loadLocationDescriptors(locations, missing, vocabulary_->dim(), descriptors.ptr<float>(),
                                  created.data());
  const std::int64_t next_word_id = vocabulary_->nextWordId();
  vocabulary_->insert(missing, descriptors, created);
  keepWordIdsInBlock(next_word_id);  // words of other writers may have larger ids
}

void MapImpl::bringBack(const std::vector<std::int64_t>& ids, FrameWrite& write,
                        FrameResult& result) {
  if (ids.empty()) return;
  // The whole references: the signature's words, and the keypoints the check will compare
  // (KeypointCache::keepPositions).
  auto refs = store_->loadWordRefs(ids);
  std::vector<std::int64_t> missing;
  for (std::int64_t id : ids) {
    CachedKeypoints positions = keypointPositions(refs[id]);
    for (WordId word : index_.add(id, Signature::fromWords(positions.words)).referenced)
      if (!vocabulary_->contains(word)) missing.push_back(word);
    keypoint_cache_.keepPositions(id, std::move(positions));
  }
  restoreWords(std::move(missing), ids);
  for (std::int64_t id : ids) {
    graph_.addNode(id);
    for (const auto& l : store_->links(id)) {
      std::int64_t other = l.location_a == id ? l.location_b : l.location_a;
      if (l.type != storage::LinkType::kMerge && graph_.hasNode(other))
        graph_.addLink(id, other, linkKindOf(l.type));
    }
  }
  tiers_->retrieveToWm(ids);
  for (std::int64_t id : ids) write.ages.emplace_back(id, tiers_->ageOf(id));
  write.to_wm.insert(write.to_wm.end(), ids.begin(), ids.end());
  result.retrieved += ids.size();
}

void MapImpl::storeLocationWords(std::int64_t location_id, const Signature& signature,
                                 FrameWrite& write) {
  // Imported words never leave RAM, so no retrieval reads them.
  storage::LocationWordDescriptors words;
  words.location_id = location_id;
  words.dim = vocabulary_->dim();
  for (const Signature::Entry& e : signature.entries()) {
    if (std::binary_search(imported_words_.begin(), imported_words_.end(), e.word)) continue;
    // Every word of a new location was just quantised to, so it is in RAM; the test only keeps
    // a missing word from being read.
    const float* descriptor = vocabulary_->descriptor(e.word);
    if (!descriptor) continue;
    words.word_ids.push_back(e.word);
    words.created_frames.push_back(vocabulary_->createdFrame(e.word));
    words.descriptors.insert(words.descriptors.end(), descriptor, descriptor + words.dim);
  }
  if (!words.word_ids.empty()) write.location_words = std::move(words);
}

void MapImpl::storePlaceCode(std::int64_t location_id, const Features& features,
                             FrameWrite& write) {
  if (features.descriptors.type() != CV_32F) return;
  if (!coder_) {
    // The first location a map stores fixes the coarse centres of every code after it.
    coder_ = PlaceCoder::train(features.descriptors, PlaceCodeSettings());
    write.place_coder = coder_->toBytes();
  }
  write.place_code = frameCode(features);
  places_.add(location_id, *write.place_code);
}

const std::vector<std::int8_t>& MapImpl::frameCode(const Features& features) {
  // One code per frame, shared by the new location and the LTM search.
  if (!frame_code_) frame_code_ = coder_->encode(features.descriptors);
  return *frame_code_;
}

void MapImpl::transferToLtm(std::int64_t hypothesis, double frame_seconds, FrameWrite& write,
                            FrameResult& result) {
  std::size_t planned = tiers_->plannedTransfers(frame_seconds);
  if (planned == 0) return;
  std::set<std::int64_t> immune;
  if (hypothesis != kNewPlace) {
    immune.insert(hypothesis);
    for (std::int64_t n : graph_.neighbours(hypothesis)) immune.insert(n);
  }
  std::vector<std::int64_t> ids = tiers_->transferCandidates(planned, immune);
  for (std::int64_t id : ids) {
    leaveIndex(index_.remove(id));
    graph_.removeNode(id);
  }
  tiers_->transferToLtm(ids);
  write.to_ltm.insert(write.to_ltm.end(), ids.begin(), ids.end());
  result.transferred = ids.size();
}

void MapImpl::leaveIndex(const WordChanges& changes) {
  std::vector<std::int64_t> leaving;
  leaving.reserve(changes.unreferenced.size());
  for (std::int64_t word : changes.unreferenced)
    if (!std::binary_search(imported_words_.begin(), imported_words_.end(), word))
      leaving.push_back(word);
  if (!leaving.empty()) vocabulary_->erase(leaving);
}

void MapImpl::commit(FrameWrite& w, FrameResult& r, const std::string& source_path) {
  const auto stage = Clock::now();
  r.vocabulary_size = vocabulary_->size();
  r.stm_size = tiers_->stm().size();
  r.wm_size = tiers_->wmSize();

  w.frame.session_id = r.session_id;
  w.frame.source_index = r.source_index;
  w.frame.source_path = source_path;
  w.frame.stamp_ns = r.stamp_ns = frame_stamp_ns_;
  w.frame.stats = {
      static_cast<std::int64_t>(r.feature_count),   static_cast<std::int64_t>(r.words_created),
      static_cast<std::int64_t>(r.vocabulary_size), static_cast<std::int64_t>(r.wm_size),
      static_cast<std::int64_t>(r.stm_size),        r.mean_quantisation_error};
  try {
    // Open already when the frame reserved ids (map_fleet.cpp).
    storage::Transaction tx = frame_tx_ ? std::move(*frame_tx_) : store_->begin();
    frame_tx_.reset();
    if (!w.words.empty()) store_->insertWords(w.words);
    if (w.new_location) {
      store_->insertLocation(*w.new_location);
      if (w.place_code) store_->putPlaceCode(w.new_location->id, *w.place_code);
      if (w.location_words) store_->putLocationWordDescriptors(*w.location_words);
      store_->insertWordRefs(w.new_location->id, w.refs);
      if (!w.keypoint_descriptors.empty())
        store_->putState(keypointDescriptorsKey(w.new_location->id), w.keypoint_descriptors);
    }
    if (!w.latest_view.empty() && w.frame.location_id)
      store_->putState(latestViewKey(*w.frame.location_id), w.latest_view);
    if (w.frame.location_id) store_->addCoveredFrame(*w.frame.location_id, r.frame_id);
    if (w.weight) store_->updateWeight(w.weight->first, w.weight->second);
    for (const auto& l : w.links) store_->insertLink(l.location_a, l.location_b, l.type, l.score);
    if (!w.to_wm.empty()) store_->setTier(w.to_wm, storage::Tier::kWm);
    if (!w.to_ltm.empty()) store_->setTier(w.to_ltm, storage::Tier::kLtm);
    if (!w.ages.empty()) store_->setWmAges(w.ages);
    if (!w.place_coder.empty()) store_->putState(kPlaceCoderKey, w.place_coder);
    if (w.hypothesis) store_->insertHypothesis(*w.hypothesis);
    if (w.frame.outcome != storage::FrameOutcome::kBad)
      store_->putPosterior(filter_->state().posterior);
    counters_.next_wm_age = tiers_->nextAge();
    counters_.tiers_digest =
        tiersDigest({tiers_->stm().begin(), tiers_->stm().end()}, tiers_->wm());
    counters_.save(*store_);
    vocabulary_state_.save(*store_, *vocabulary_);
    // The frame's row goes last (foreign keys are checked at commit) so that its storage_ms
    // holds the time of every other write of the frame; only this insert and the COMMIT (a WAL
    // append, no fsync under synchronous=NORMAL) are missing from it. The log's storage time,
    // taken after the commit, has them.
    const auto& t = r.times;
    const double storage_ms = msSince(stage);
    w.frame.timings = {
        t.features,
        t.quantisation,
        t.likelihood,
        t.filter,
        t.memory,
        storage_ms,
        t.features + t.quantisation + t.likelihood + t.filter + t.memory + storage_ms};
    store_->insertFrame(w.frame);
    if (w.frames_of) r.hypothesis.frames = framesOf(*w.frames_of);
    tx.commit();
  } catch (...) {
    broken_ = true;  // RAM is one frame ahead of the file now
    throw;
  }
  r.times.storage = msSince(stage);
  r.times.total = r.times.features + r.times.quantisation + r.times.likelihood + r.times.filter +
                  r.times.memory + r.times.storage;
}

void MapImpl::readAhead(std::int64_t hypothesis) {
  if (options_.read_ahead_links <= 0 || storage::isServerMap(store_->path())) {
    read_ahead_.reset();
    return;
  }
  // Only a place in long-term memory is ever read back: with none, every row it would read is
  // one the frames never ask for, and its thread would take CPU from the frame's own.
  if (tiers_->ltmSize() == 0) return;
  // The hypothesis first: the next frame brings back its LTM neighbours.
  std::vector<std::int64_t> places;
  if (hypothesis != kNewPlace) places.push_back(hypothesis);
  places.insert(places.end(), read_ahead_places_.begin(), read_ahead_places_.end());
  if (places.empty()) return;
  if (!read_ahead_) {
    ReadAheadSettings settings;
    settings.links = options_.read_ahead_links;
    read_ahead_ = std::make_unique<ReadAhead>(store_->path(), settings);
  }
  read_ahead_->ahead(std::move(places));
}

std::vector<FrameRef> MapImpl::framesOf(std::int64_t location_id) const {
  std::vector<FrameRef> out;
  for (std::int64_t frame_id : store_->coveredFrames(location_id)) {
    auto f = store_->frame(frame_id);
    if (!f) continue;
    out.push_back({f->id, f->session_id, f->source_index, f->source_path, f->stamp_ns});
  }
  std::sort(out.begin(), out.end(),
            [](const FrameRef& a, const FrameRef& b) { return a.frame_id < b.frame_id; });
  return out;
}

}  // namespace placedb
