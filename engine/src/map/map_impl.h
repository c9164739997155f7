#pragma once
// The engine behind placedb::Map: the per-frame pipeline over the storage, vocabulary, memory
// tiers and Bayes filter. One MapImpl owns one open map file.
#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "decision/agreeing_place.h"
#include "decision/way_here.h"
#include "features/feature_extractor.h"
#include "filter/bayes_filter.h"
#include "filter/inverted_index.h"
#include "filter/link_graph.h"
#include "geometry/geometry.h"
#include "map/engine_state.h"
#include "map/read_ahead.h"
#include "map/state_keys.h"
#include "memory/memory_tiers.h"
#include "memory/place_code.h"
#include "memory/place_index.h"
#include "memory/place_neighbourhood.h"
#include "placedb/map.h"
#include "placedb/storage/map_store.h"
#include "vocabulary/vocabulary.h"

namespace placedb {

// The graph's kind of a stored link (merge links never enter the graph).
inline LinkKind linkKindOf(storage::LinkType type) {
  return type == storage::LinkType::kLoopClosure ? LinkKind::kLoopClosure : LinkKind::kNeighbour;
}

class MapImpl final : public Map {
 public:
  MapImpl(const std::string& path, const Options& options, Mode mode);
  ~MapImpl() override;

  std::optional<SessionInfo> lastSession() const override;
  std::vector<SessionInfo> sessions() const override;
  std::map<std::string, std::string> sessionSettings(std::int64_t session_id) const override;
  SessionInfo beginSession(const std::string& source,
                           const std::string& source_digest = "") override;
  SessionInfo resumeSession(std::int64_t session_id) override;
  FrameResult process(const cv::Mat& image, std::int64_t source_index,
                      const std::string& source_path,
                      std::optional<std::int64_t> stamp_ns = std::nullopt) override;
  FrameResult recordUnreadable(std::int64_t source_index, const std::string& source_path,
                               std::optional<std::int64_t> stamp_ns = std::nullopt) override;
  QueryResult query(const cv::Mat& image, std::size_t top_k) override;
  std::size_t importVocabulary(const std::string& file, bool text, VocabularyMode mode) override;
  void close() override;
  const Options& options() const override { return options_; }
  const std::string& path() const override { return store_->path(); }

  // For tests: empty when every location is in exactly one tier, the inverted index holds
  // exactly the STM and WM signatures and the vocabulary exactly their words; else the problem.
  std::string checkConsistency() const;
  // For tests: the place codes and how their search runs (exact, or lists trained).
  const PlaceIndex& placeIndex() const { return places_; }

 private:
  // What one frame writes, gathered while it is processed and committed in one transaction.
  struct FrameWrite;

  void configure(const Options& options);  // builds extractor, vocabulary, filter, tiers
  void restoreFromStore();                 // STM, WM, index, filter, counters
  void requireSession(const char* what) const;
  void requireWritable(const char* what) const;
  SessionInfo toInfo(const storage::SessionRecord& record) const;

  // One frame, as named steps: quantise -> place in STM -> search LTM -> likelihood and filter
  // -> decide the loop closure -> manage memory -> commit.
  FrameResult processFeatures(const Features& features, std::int64_t source_index,
                              const std::string& source_path, double features_ms);
  struct Quantised {
    Signature signature;
    std::vector<std::int64_t> word_of_feature;  // -1 where a feature got no word
    std::vector<std::int64_t> created_words;
  };
  Quantised quantise(const Features& features, FrameResult& result, FrameWrite& write);
  // Merges the frame into the newest location or makes a new one (with its place code).
  void placeInShortTermMemory(const Features& features, const Quantised& q, FrameResult& result,
                              FrameWrite& write);
  // The frame's quantised keypoints as references (into `refs`) and their own descriptors.
  static cv::Mat quantisedKeypoints(const Features& features, const Quantised& q,
                                    std::vector<storage::WordRef>& refs);
  // A merged frame's view as its location keeps it (latest_view.h).
  static std::vector<std::uint8_t> latestViewOf(const Features& features, const Quantised& q,
                                                std::int64_t frame_id);
  // Brings back the LTM locations whose place codes rank among the ltm_search most like the frame.
  void searchLongTermMemory(const Features& features, FrameWrite& write, FrameResult& result);
  // Verifies the filter's outcome and records the decision; returns the reported hypothesis.
  std::int64_t decideLoopClosure(const FilterOutcome& outcome, const Features& features,
                                 const Quantised& q,
                                 const std::vector<LocationSimilarity>& similarities,
                                 FrameResult& result, FrameWrite& write, StageTimes& times);
  // An accepted closure's relative pose when this session and the hypothesis' have intrinsics;
  // without one, `why` (when given) says what was missing.
  std::optional<storage::ClosurePose> closurePose(std::int64_t hypothesis,
                                                  const GeometricResult& geometry,
                                                  std::string* why = nullptr);
  CameraIntrinsics sessionIntrinsics(std::int64_t session_id);  // cached per session
  // Retrieval around the hypothesis, then transfer; memory_ms is this frame's time in the
  // stages that grow with memory, which the time budget (t_time_ms) bounds.
  void manageMemory(std::int64_t hypothesis, double memory_ms, FrameWrite& write,
                    FrameResult& result);
  FrameResult recordBad(std::int64_t source_index, const std::string& source_path,
                        std::size_t feature_count, const StageTimes& times);
  // Runs one frame; when it fails after reserving ids, their transaction rolls back and the map
  // must be reopened (broken_).
  FrameResult abandonOnError(const std::function<FrameResult()>& frame);
  // Picks the reported hypothesis among the filter's best and its WM neighbours and verifies
  // it; fills result.hypothesis (location, posterior, score, acceptance, reason).
  struct Verified {
    std::int64_t location = 0;  // kNewPlace (-1) when there is none
    bool passed = false;        // the geometric check (or no check) let it through
    int inliers = 0;
    int matches = 0;             // descriptor matches behind the inliers
    bool temporal = false;       // passed on the relaxed rule, near the last accepted closure
    bool continues_run = false;  // lies within the reach of the closure run (closure_run.h)
    int checked = 0;             // candidates the check ran on
    double log10_nfa = 0;        // the reported candidate's false alarms over `places`, log10
    GeometricResult geometry;    // the reported candidate's check (its agreeing pairs)
    // When `geometry` compared the reported place's latest view: its first frame's comparison,
    // in whose camera the closure's pose is measured. Only for an accepted closure and
    // intrinsics known.
    std::optional<GeometricResult> pose_geometry;
    ClosureEvidence evidence;  // the check's evidence over the frames up to this one
    bool by_evidence = false;  // passed as a run of frames, not as this frame alone
    int places = 1;            // candidates the false alarms were counted over
    // Set when the place passed the check but shares too little of the frame's scene
    // (scene_extent.h): an object, not the place. The frame is then refused.
    std::optional<SceneShare> object_only;
    // Set with object_only when the place lies in the closure run's reach and
    // temporal_end_on_object is on: the camera has left the places the run follows.
    bool ends_run = false;
    // Set when the closure is not what the frame's agreement singles out (way_here.h): the
    // camera never left the place's scene, a place of its way here agrees about as well, or the
    // frame claims again a place refused so just before. The frame is refused.
    std::optional<WayHereRefusal> way_here;
  };
  // Links the frame's location to the accepted closure; one that passed on its own anchors the
  // closure run (closure_run.h).
  void acceptLoopClosure(std::int64_t hypothesis, const Verified& verified, FrameResult& result,
                         FrameWrite& write);
  // `own_view` is the frame's previous view of its own scene (the location it merged into, or
  // the one before its new location; 0 when there is none), against which a closure's share of
  // the scene is measured.
  Verified verifyHypothesis(const FilterOutcome& outcome, const Features& features,
                            const Quantised& q, const std::vector<LocationSimilarity>& similarities,
                            std::int64_t frame_id, LocationId own_view);
  // Why a hypothesis was not accepted, for the log and the map's hypotheses table.
  static std::string rejectionOf(const FilterOutcome& outcome, const Verified& verified);
  // The frame's previous view of its own scene (see verifyHypothesis), 0 when there is none.
  LocationId ownViewOf(const FrameResult& r) const;
  // The location before `location` on its traversal (its neighbour link), 0 when none is live.
  LocationId traversalPredecessor(LocationId location) const;
  // The share of the frame's scene that an accepted place's comparison covers (scene_extent.h).
  SceneShare sceneOf(const GeometricResult& place, LocationId own_view, const GeometricView& query);
  // The frame's traversal back from `own_view` (newest first) to the accepted place's
  // surroundings (way_here.h); `reaches` tells whether it got there.
  std::vector<LocationId> wayHere(LocationId accepted, LocationId own_view, bool& reaches) const;
  // Why a closure that starts a run is not the place its agreement singles out (way_here.h);
  // nothing when it is. `accepted_log10_nfa` is the evidence the acceptance rests on.
  std::optional<WayHereRefusal> judgeWayHere(LocationId accepted, LocationId own_view,
                                             const GeometricView& query, const Signature& signature,
                                             double accepted_log10_nfa);
  // The refusal of a frame that claims (accepted, reported) within a closure run's reach of the
  // place refused as a pattern just before (way_here.h); nothing when it does not.
  std::optional<WayHereRefusal> continuedRefutation(const std::array<LocationId, 2>& claimed,
                                                    std::int64_t frame_id,
                                                    double accepted_log10_nfa) const;
  // Places a loop closure joins to the accepted place's stretch of its traversal (within
  // temporal_radius links): earlier visits of it, which no way here counts as another place.
  std::set<LocationId> earlierVisitsOf(LocationId accepted) const;
  // The WM locations that continue the closure run at this frame (closure_run.h), sorted; empty
  // when temporal consistency is off or the frame continues no run.
  std::vector<LocationId> nearLastClosure(std::int64_t frame_id) const;
  // The WM locations within reach of the last frame's match, sorted; empty when this frame does
  // not follow it or the check has no chance level (closure_evidence.h).
  std::vector<LocationId> continuingEvidence(std::int64_t frame_id) const;
  // Of an accepted place and its traversal neighbours in WM, the one `query` agrees with best
  // (agreeing_place.h).
  std::optional<AgreeingPlace> agreeingPlace(LocationId accepted, const GeometricView& query);
  // A frame's own evidence for the run: its NFA over the `places` it chose among, or at most
  // geometry_max_nfa when it passed.
  double frameEvidence(const GeometricResult& g, int places) const;
  // The relaxed rule (temporal_*) for a candidate near the last accepted closure.
  bool passesNearLastClosure(const GeometricResult& g) const;
  const CachedKeypoints& keypointsOf(std::int64_t location_id);   // from the cache or the file
  CachedKeypoints loadKeypoints(std::int64_t location_id) const;  // from the file
  static CachedKeypoints keypointPositions(const std::vector<storage::WordRef>& refs);
  void loadKeypointCodes(std::int64_t location_id, CachedKeypoints& entry) const;
  GeometricView viewOf(const CachedKeypoints& keypoints) const;
  // A location's stored view for the geometric check; nothing when it has no keypoints.
  std::optional<GeometricView> placeView(LocationId location);
  // The view of the latest frame merged into a location (latest_view.h); nothing when it has
  // none or geometry_latest_view is off.
  std::optional<GeometricView> latestView(LocationId location) const;
  // Of a place's views, the comparison `query` agrees with on the most pairs (the first
  // frame's on a tie); nothing when it has no keypoints. `at_least` as ComparisonCheck's.
  std::optional<GeometricResult> bestViewComparison(LocationId location, const GeometricView& query,
                                                    int at_least);
  void retrieveNeighbours(std::int64_t hypothesis, FrameWrite& write, FrameResult& result);
  // Moves LTM locations back to WM: signatures, missing words, links, ages.
  void bringBack(const std::vector<std::int64_t>& ids, FrameWrite& write, FrameResult& result);
  // Words of the file that the vocabulary lacks go back into it with their stored descriptors
  // (repeats allowed), read from the rows of the `locations` that reference them.
  void restoreWords(std::vector<std::int64_t> missing, const std::vector<std::int64_t>& locations);
  // The descriptors of a new location's words, written beside it so that bringing it back from
  // long-term memory reads one row (table location_word_descriptors).
  void storeLocationWords(std::int64_t location_id, const Signature& signature, FrameWrite& write);
  void storePlaceCode(std::int64_t location_id, const Features& features, FrameWrite& write);
  const std::vector<std::int8_t>& frameCode(const Features& features);
  void transferToLtm(std::int64_t hypothesis, double frame_seconds, FrameWrite& write,
                     FrameResult& result);
  void enterWorkingMemory(const std::vector<std::int64_t>& ids, FrameWrite& write);
  void leaveIndex(const WordChanges& changes);  // unreferenced words leave, imported ones stay
  void commit(FrameWrite& write, FrameResult& result, const std::string& source_path);
  // After the commit: the places the next frame may bring back are read on another thread.
  void readAhead(std::int64_t hypothesis);
  std::vector<FrameRef> framesOf(std::int64_t location_id) const;

  // Fleet maps (map_fleet.cpp): several writers of one map on a server, each in its own session.
  // Begins a session that keeps its own memory, a copy of the main line's (another writer holds
  // the main line).
  SessionInfo beginSideSession(const std::string& source, const std::string& source_digest);
  // What beginSession does to the memory it starts from: the previous session's STM becomes
  // loop candidates and its newest location is no longer this one's.
  void startSessionMemory(std::int64_t session_id);
  // Ids for the frame about to be processed, which may create `words` words: reserves blocks
  // in the frame's transaction (opened here) where the writer's run out.
  void reserveIds(std::int64_t words);
  // A frame's place in its session's order, for closure runs and evidence (engine_state.h).
  std::int64_t frameClock(std::int64_t frame_id) const {
    return frame_id - counters_.frame_clock_shift;
  }
  // Adds the places other writers stored since the last look to long-term memory, where the LTM
  // search and retrieval find them.
  void learnOtherWritersPlaces();
  // After the vocabulary took in words of other writers, its next word id back in this
  // writer's block.
  void keepWordIdsInBlock(std::int64_t next_word_id);
  SessionInfo sessionInfo(std::int64_t session_id) const;
  // Localisation: makes the vocabulary complete (the words of LTM locations too) and indexes
  // the LTM signatures, once, when the map's words fit the budget; else leaves LTM to the codes.
  void loadLtmWords();
  void loadPlaceNeighbourhood();  // localisation: the neighbour links over the place codes

  std::unique_ptr<storage::MapStore> store_;
  std::unique_ptr<ReadAhead> read_ahead_;  // started by the first frame with places to read
  Mode mode_;
  std::optional<std::int64_t> frame_stamp_ns_;  // the source's stamp of the frame in flight
  Options options_;
  std::unique_ptr<FeatureExtractor> extractor_;
  std::unique_ptr<vocab::Vocabulary> vocabulary_;
  InvertedIndex index_;  // signatures of STM and WM locations
  LinkGraph graph_;      // links among STM and WM locations
  std::unique_ptr<MemoryTiers> tiers_;
  std::unique_ptr<BayesFilter> filter_;
  std::optional<PlaceCoder> coder_;  // absent until the map's first location
  PlaceIndex places_;                // the place code of every location, every tier
  // Localisation only: the signatures of LTM locations, their words added to the vocabulary,
  // loaded by the first query when the map's words fit kQueryWordBudget (map_query.cpp).
  std::optional<InvertedIndex> ltm_words_;
  // Localisation only: the neighbour links of every location over the place codes, for the
  // query's code search (built by the first query).
  std::optional<PlaceNeighbourhood> place_neighbourhood_;
  std::optional<std::vector<std::int8_t>> frame_code_;  // the current frame's, once computed
  std::vector<LocationId> searched_back_;  // brought back from LTM by this frame's code search
  std::vector<std::int64_t> read_ahead_places_;  // all this frame's code search ranked, in order
  KeypointCache keypoint_cache_;  // of WM locations the geometric check compared frames with
  EngineCounters counters_;
  VocabularyStateWriter vocabulary_state_;
  std::vector<std::int64_t> imported_words_;  // ascending; never leave the index
  std::optional<std::int64_t> session_id_;
  // Fleet maps: the frame's transaction, opened before processing when it reserves ids; the
  // newest location of every session this writer knows; whether RAM holds the main line's memory
  // as read while this writer held the main line (not a side session's, nor a copy read while
  // another writer held it).
  std::optional<storage::Transaction> frame_tx_;
  std::map<std::int64_t, std::int64_t> newest_known_;
  bool main_memory_ = false;
  std::map<std::int64_t, CameraIntrinsics> session_intrinsics_;  // other sessions', as read
  bool closed_ = false;
  bool broken_ = false;  // a failed commit left RAM ahead of the file: reopen to continue
};

}  // namespace placedb
