#pragma once
// The online visual vocabulary: words held in RAM (those of STM/WM locations), their kd-index, and
// the quantisation of an image's descriptors into word ids by the greedy rule (paper 000,
// algorithm 3) or the NNDR rule (algorithms 1-2).
//
// Distances. The index works in squared Euclidean distance. DistanceUnit says in which unit ND and
// NND are compared with T_ND1, T_ND2 and T_NNDR: kSquared (default) follows RTAB-Map, whose FLANN
// L2 distances are squared, so ND/NND > T_NNDR is a ratio of squared distances; kEuclidean takes
// square roots first. Quantisation errors are always reported in plain Euclidean units.
//
// Fewer than two candidates. With no word at all (empty vocabulary and none created yet from this
// image) ND = NND = +inf and the feature creates a word under both rules (fixed mode: it gets no
// word, id -1). With exactly one candidate NND = +inf: the ratio test reads ND > T_NNDR * NND,
// which is false, so NNDR gives the nearest word; greedy first applies T_ND2 / T_ND1 as usual.
//
// Determinism. Every answer is a function of the sequence of calls (quantize/insert/erase/restore)
// only: the index has no background work and no unseeded randomness, and distance ties go to the
// smaller word id. state()/restore() carry that sequence's effect across a restart exactly.
//
// Not thread-safe: one thread at a time (searches reuse per-query scratch marks).
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "placedb/options.h"
#include "vocabulary/id_table.h"
#include "vocabulary/kd_forest.h"
#include "vocabulary/slot_store.h"

namespace placedb::vocab {

using placedb::DistanceUnit;
using placedb::WordRule;

// Defaults are Options' (word_rule, distance_unit, t_nndr, t_nd1, t_nd2, kd_trees, kd_checks).
struct VocabularyOptions {
  WordRule rule = Options().word_rule;
  DistanceUnit unit = Options().distance_unit;
  float t_nndr = static_cast<float>(Options().t_nndr);  // [0, 1]
  float t_nd1 = static_cast<float>(Options().t_nd1);    // [0, 1e30], in `unit`
  float t_nd2 = static_cast<float>(Options().t_nd2);    // [t_nd1, 1e30], in `unit`
  int kd_trees = Options().kd_trees;                    // [1, 64]
  // Points compared per search (whole buckets, so it may overshoot by a bucket). With 4 trees and
  // 8-point buckets, 64 gave 0.964 nearest-neighbour recall on 1M clustered 64-d words and 0.982
  // on 100k (bench/vocabulary/README.md); 16-point buckets gave 0.89 at 1M.
  int checks = Options().kd_checks;  // [1, 1048576]
  int leaf_size = 8;                 // points per kd-tree bucket before it splits, [1, 4096]
  std::uint64_t seed = 0x706c616365646231ull;  // the forest's split choices
  bool fixed = false;                          // no new words: every feature takes its nearest word
  // Threads searching a frame's features at once, 0 = one per hardware thread, [0, 64]. Each
  // search reads the forest only, so the words chosen never depend on it.
  int threads = Options().threads;

  // Throws placedb::Error(kInvalidArgument) naming the first setting out of range.
  void validate() const;
  // Key/value form, for the vocabulary file header.
  std::map<std::string, std::string> toSettings() const;
};

struct Quantization {
  std::vector<std::int64_t> word_of_feature;  // -1 only in fixed mode with no word at all
  std::vector<std::int64_t> created_words;    // in creation order (ids ascending)
  std::vector<float> distance_of_feature;     // Euclidean, feature -> its word (0 if it created it)
  double mean_error = 0;                      // mean of distance_of_feature, 0 for no feature
};

// What must be persisted so that restore() reproduces the index exactly: the settings, the next
// word id and the forest's internal nodes. An engine need not rewrite the nodes each time:
// Vocabulary::takeIndexChanges() gives the nodes that changed. `legacy_splits` is the split log
// that maps of schema 2 stored instead of nodes; restore() converts it.
struct IndexState {
  int dim = 0;
  int kd_trees = 0;
  int leaf_size = 0;
  std::uint64_t seed = 0;
  std::int64_t next_word_id = 0;
  std::vector<ForestNode> nodes;
  std::vector<SplitRecord> legacy_splits;

  std::vector<std::uint8_t> serialize() const;  // little-endian, versioned
  // Throws placedb::Error(kInvalidArgument) on bytes that are not a valid state.
  static IndexState deserialize(const std::vector<std::uint8_t>& bytes);
  bool operator==(const IndexState& o) const;
};

// Appends the records of a schema-2 split log (11 bytes each: tree, node, dim, value, as IndexState
// version 1 and the engine's split-log chunks hold them) to `out`; false, appending nothing, when
// `size` is not a whole number of records.
bool appendSplitRecords(const std::uint8_t* data, std::size_t size, std::vector<SplitRecord>* out);

class Vocabulary {
 public:
  Vocabulary(VocabularyOptions options, int dim, std::string extractor_signature);

  // Assigns every row of `descriptors` (CV_32F, dim columns) a word, creating words (created
  // frame = frame_id) that enter the index at once.
  Quantization quantize(const cv::Mat& descriptors, std::int64_t frame_id);

  // Words coming back into RAM (retrieval) or loaded at start. Ids must not be active;
  // nextWordId() becomes at least max(id) + 1.
  void insert(const std::vector<std::int64_t>& ids, const cv::Mat& descriptors,
              const std::vector<std::int64_t>& created_frames);
  // Words leaving RAM (their locations all went to LTM); their descriptors are dropped.
  // Unknown ids are an error (kInvalidArgument).
  void erase(const std::vector<std::int64_t>& ids);

  bool contains(std::int64_t id) const { return id >= 0 && slot_of_.find(id) != IdTable::kNone; }
  std::size_t size() const { return slot_of_.size(); }
  std::int64_t nextWordId() const { return next_word_id_; }
  // The next word created gets `next_word_id`, even below a word in RAM: for a map whose writers
  // each create words from blocks of ids of their own, where words brought back from another
  // writer may have larger ids than this one's next (insert() and restore() would otherwise take
  // the next id past them, into the other writer's block). The caller vouches that none of the
  // ids it will create this way is in RAM.
  void continueAt(std::int64_t next_word_id);
  const float* descriptor(std::int64_t id) const;    // nullptr if not in RAM
  std::int64_t createdFrame(std::int64_t id) const;  // -1 if not in RAM
  std::vector<std::int64_t> ids() const;             // ascending
  int dim() const { return dim_; }
  const VocabularyOptions& options() const { return options_; }
  const std::string& extractorSignature() const { return extractor_; }

  // Search effort: changes no index state, but does change approximate answers, so a resumed run
  // must use the same value to stay bit-identical. Throws kInvalidArgument outside [1, 1000000].
  void setChecks(int checks);

  // The k nearest words (approximate, `checks` of the options), plain Euclidean distances.
  std::vector<std::pair<std::int64_t, float>> knn(const float* query, int k) const;

  IndexState state() const;  // copies every node: for tests and full saves
  // The engine's cheap path: the forest nodes that changed since the last call (or since
  // restore()); applied to the stored copy they give state().nodes.
  void takeIndexChanges(ForestChanges* out) { forest_->takeChanges(out); }
  // Nodes allocated in the forest (internal, leaves and free ones): follows the words in RAM.
  std::size_t indexNodeCount() const { return forest_->nodeCount(); }
  // On a Vocabulary that has seen no call yet: rebuilds the index from the persisted state and
  // the words in RAM at that point (ids, their descriptors and created frames, any order). No
  // erased word is needed. A state with legacy_splits is converted: the next takeIndexChanges()
  // is a full one.
  void restore(const IndexState& state, const std::vector<std::int64_t>& ids,
               const cv::Mat& descriptors, const std::vector<std::int64_t>& created_frames);
  // The same, with descriptors read straight into the index's storage: `load(begin, count, rows,
  // created)` writes the descriptors of ids[begin, begin + count) to `rows` (count x dim floats,
  // contiguous) and their created frames to `created`.
  using DescriptorLoader =
      std::function<void(std::size_t begin, std::size_t count, float* rows, std::int64_t* created)>;
  void restore(const IndexState& state, const std::vector<std::int64_t>& ids,
               const DescriptorLoader& load);

 private:
  void checkDescriptors(const cv::Mat& descriptors, const char* what) const;
  // A word's descriptor into the store, by id; the caller inserts its slot into the forest.
  std::uint32_t storeWord(std::int64_t id, std::int64_t created_frame, const float* descriptor);
  bool decideNewWord(const std::vector<Neighbor>& best) const;
  float inUnit(float dist2) const;

  VocabularyOptions options_;
  int dim_;
  std::string extractor_;
  SlotStore store_;
  std::unique_ptr<KdForest> forest_;
  IdTable slot_of_;
  std::int64_t next_word_id_ = 0;
  bool touched_ = false;
};

}  // namespace placedb::vocab
