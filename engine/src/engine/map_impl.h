#pragma once
// The engine behind placedb::Map: the per-frame pipeline over the storage, vocabulary, memory
// tiers and Bayes filter. One MapImpl owns one open map file.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "engine/engine_state.h"
#include "engine/geometric_check.h"
#include "engine/state_keys.h"
#include "features/feature_extractor.h"
#include "filter/bayes_filter.h"
#include "filter/inverted_index.h"
#include "filter/link_graph.h"
#include "memory/memory_tiers.h"
#include "placedb/map.h"
#include "placedb/storage/map_store.h"
#include "vocabulary/vocabulary.h"

namespace placedb {

class MapImpl final : public Map {
 public:
  MapImpl(const std::string& path, const Options& options, Mode mode);
  ~MapImpl() override;

  std::optional<SessionInfo> lastSession() const override;
  std::vector<SessionInfo> sessions() const override;
  std::map<std::string, std::string> sessionSettings(std::int64_t session_id) const override;
  SessionInfo beginSession(const std::string& source) override;
  SessionInfo resumeSession(std::int64_t session_id) override;
  FrameResult process(const cv::Mat& image, std::int64_t source_index,
                      const std::string& source_path) override;
  FrameResult recordUnreadable(std::int64_t source_index, const std::string& source_path) override;
  QueryResult query(const cv::Mat& image, std::size_t top_k) override;
  std::size_t importVocabulary(const std::string& file, bool text, VocabularyMode mode) override;
  void close() override;
  const Options& options() const override { return options_; }
  const std::string& path() const override { return store_->path(); }

  // For tests: empty when every location is in exactly one tier, the inverted index holds
  // exactly the STM and WM signatures and the vocabulary exactly their words; else the problem.
  std::string checkConsistency() const;

 private:
  // What one frame writes, gathered while it is processed and committed in one transaction.
  struct FrameWrite;

  void configure(const Options& options);  // builds extractor, vocabulary, filter, tiers
  void restoreFromStore();                 // STM, WM, index, filter, counters
  void requireSession(const char* what) const;
  void requireWritable(const char* what) const;
  SessionInfo toInfo(const storage::SessionRecord& record) const;

  FrameResult processFeatures(const Features& features, std::int64_t source_index,
                              const std::string& source_path, double features_ms);
  FrameResult recordBad(std::int64_t source_index, const std::string& source_path,
                        std::size_t feature_count, const StageTimes& times);
  // Picks the reported hypothesis among the filter's best and its WM neighbours and verifies
  // it; fills result.hypothesis (location, posterior, score, acceptance, reason).
  struct Verified {
    std::int64_t location = 0;  // kNewPlace (-1) when there is none
    bool passed = false;        // the geometric check (or no check) let it through
    int inliers = 0;
    int matches = 0;        // descriptor matches behind the inliers
    bool temporal = false;  // passed on temporal_min_inliers, near the last accepted closure
  };
  Verified verifyHypothesis(const FilterOutcome& outcome, const Features& features,
                            const std::vector<LocationSimilarity>& similarities,
                            std::int64_t frame_id);
  // WM locations within temporal_radius links of the last accepted loop closure, sorted; empty
  // when temporal consistency is off or that closure is too old or from another session.
  std::vector<LocationId> nearLastClosure(std::int64_t frame_id) const;
  GeometricView viewOf(std::int64_t location_id, const std::vector<storage::WordRef>& refs) const;
  void retrieveNeighbours(std::int64_t hypothesis, FrameWrite& write, FrameResult& result);
  void transferToLtm(std::int64_t hypothesis, double frame_seconds, FrameWrite& write,
                     FrameResult& result);
  void enterWorkingMemory(const std::vector<std::int64_t>& ids, FrameWrite& write);
  void leaveIndex(const WordChanges& changes);  // unreferenced words leave, imported ones stay
  void commit(FrameWrite& write, FrameResult& result, const std::string& source_path);
  std::vector<FrameRef> framesOf(std::int64_t location_id) const;

  std::unique_ptr<storage::MapStore> store_;
  Mode mode_;
  Options options_;
  std::unique_ptr<FeatureExtractor> extractor_;
  std::unique_ptr<vocab::Vocabulary> vocabulary_;
  InvertedIndex index_;  // signatures of STM and WM locations
  LinkGraph graph_;      // links among STM and WM locations
  std::unique_ptr<MemoryTiers> tiers_;
  std::unique_ptr<BayesFilter> filter_;
  EngineCounters counters_;
  VocabularyStateWriter vocabulary_state_;
  std::vector<std::int64_t> imported_words_;  // ascending; never leave the index
  std::optional<std::int64_t> session_id_;
  bool closed_ = false;
  bool broken_ = false;  // a failed commit left RAM ahead of the file: reopen to continue
};

}  // namespace placedb
