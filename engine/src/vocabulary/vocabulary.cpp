#include "vocabulary/vocabulary.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>

#include "features/feature_options.h"
#include "features/parallel_for.h"
#include "placedb/error.h"

namespace placedb::vocab {

namespace {

// Features searched together, their steps interleaved (KdForest::search): enough to keep
// several loads in flight, few enough that their marks and queues stay in L1 cache.
constexpr int kSearchGroup = 8;

[[noreturn]] void fail(const std::string& message) {
  throw Error(ErrorCode::kInvalidArgument, "vocabulary: " + message);
}

// For checks once per call; a check per word tests first and only then builds its message
// (a retrieval checks thousands of words a frame).
void require(bool ok, const std::string& message) {
  if (!ok) fail(message);
}

std::string formatFloat(float v) {
  std::ostringstream out;
  out.precision(9);
  out << v;
  return out.str();
}

}  // namespace

void VocabularyOptions::validate() const {
  require(rule == WordRule::kGreedy || rule == WordRule::kNndr, "rule must be greedy or nndr");
  require(unit == DistanceUnit::kSquared || unit == DistanceUnit::kEuclidean,
          "distance unit must be squared or euclidean");
  require(t_nndr >= 0 && t_nndr <= 1, "t_nndr must be in [0, 1], got " + formatFloat(t_nndr));
  require(t_nd1 >= 0 && t_nd1 <= 1e30f, "t_nd1 must be in [0, 1e30], got " + formatFloat(t_nd1));
  require(t_nd2 >= t_nd1 && t_nd2 <= 1e30f,
          "t_nd2 must be in [t_nd1, 1e30], got " + formatFloat(t_nd2));
  require(kd_trees >= 1 && kd_trees <= 64,
          "kd_trees must be in [1, 64], got " + std::to_string(kd_trees));
  require(checks >= 1 && checks <= (1 << 20),
          "checks must be in [1, 1048576], got " + std::to_string(checks));
  require(threads >= 0 && threads <= 64,
          "threads must be in [0, 64], got " + std::to_string(threads));
  require(leaf_size >= 1 && leaf_size <= 4096,
          "leaf_size must be in [1, 4096], got " + std::to_string(leaf_size));
}

std::map<std::string, std::string> VocabularyOptions::toSettings() const {
  return {{"rule", toString(rule)},           {"distance_unit", toString(unit)},
          {"t_nndr", formatFloat(t_nndr)},    {"t_nd1", formatFloat(t_nd1)},
          {"t_nd2", formatFloat(t_nd2)},      {"kd_trees", std::to_string(kd_trees)},
          {"checks", std::to_string(checks)}, {"leaf_size", std::to_string(leaf_size)},
          {"seed", std::to_string(seed)},     {"fixed", fixed ? "true" : "false"}};
}

Vocabulary::Vocabulary(VocabularyOptions options, int dim, std::string extractor_signature)
    : options_(options), dim_(dim), extractor_(std::move(extractor_signature)), store_(dim) {
  options_.validate();
  require(dim >= 1 && dim <= 4096, "dimension must be in [1, 4096], got " + std::to_string(dim));
  forest_ =
      std::make_unique<KdForest>(&store_, options_.kd_trees, options_.leaf_size, options_.seed);
}

void Vocabulary::checkDescriptors(const cv::Mat& descriptors, const char* what) const {
  if (descriptors.empty()) return;
  require(descriptors.type() == CV_32F, std::string(what) + ": descriptors must be CV_32F");
  require(descriptors.cols == dim_, std::string(what) + ": descriptors have " +
                                        std::to_string(descriptors.cols) +
                                        " columns, the vocabulary " + std::to_string(dim_));
  require(cv::checkRange(descriptors, true),
          std::string(what) + ": descriptors must be finite (no NaN or infinity)");
}

float Vocabulary::inUnit(float dist2) const {
  return options_.unit == DistanceUnit::kSquared ? dist2 : std::sqrt(dist2);
}

bool Vocabulary::decideNewWord(const std::vector<Neighbor>& best) const {
  if (best.empty()) return true;  // ND = NND = +inf
  const float nd = inUnit(best[0].dist2);
  if (options_.rule == WordRule::kGreedy) {
    if (nd > options_.t_nd2) return true;
    if (nd < options_.t_nd1) return false;
  }
  // Without a second word the ratio cannot show the match is distinctive: a new word. (Taking
  // the only word instead sends every later feature of an NNDR run to word 0, forever.)
  if (best.size() < 2) return true;
  // ND/NND > T_NNDR, written without the division: 0/0 gives false.
  return nd > options_.t_nndr * inUnit(best[1].dist2);
}

std::uint32_t Vocabulary::storeWord(std::int64_t id, std::int64_t created_frame,
                                    const float* descriptor) {
  const std::uint32_t slot = store_.add(id, created_frame, descriptor);
  slot_of_.set(id, slot);
  return slot;
}

Quantization Vocabulary::quantize(const cv::Mat& descriptors, std::int64_t frame_id) {
  checkDescriptors(descriptors, "quantize");
  touched_ = true;
  const int m = descriptors.rows;
  Quantization q;
  q.word_of_feature.assign(m, -1);
  q.distance_of_feature.assign(m, 0.f);
  if (m == 0) return q;
  const cv::Mat rows = descriptors.isContinuous() ? descriptors : descriptors.clone();
  auto row = [&](int i) { return rows.ptr<float>(i); };

  // ND, NND and nearest word of every feature against V_{t-1}.
  std::vector<std::vector<Neighbor>> best(m);
  const std::size_t k = options_.fixed ? 1 : 2;
  std::vector<const float*> queries(m);
  std::vector<std::vector<Neighbor>*> outs(m);
  for (int i = 0; i < m; ++i) {
    queries[i] = row(i);
    outs[i] = &best[i];
  }
  const int groups = (m + kSearchGroup - 1) / kSearchGroup;
  parallelFor(groups, resolveThreadCount(options_.threads), [&](int g) {
    const int first = g * kSearchGroup;
    forest_->search(queries.data() + first, outs.data() + first,
                    static_cast<std::size_t>(std::min(kSearchGroup, m - first)), k,
                    options_.checks);
  });

  if (options_.fixed) {
    double sum = 0;
    for (int i = 0; i < m; ++i) {
      if (best[i].empty()) continue;
      q.word_of_feature[i] = best[i][0].id;
      q.distance_of_feature[i] = std::sqrt(best[i][0].dist2);
      sum += q.distance_of_feature[i];
    }
    q.mean_error = sum / m;
    return q;
  }

  std::vector<int> order(m);
  std::iota(order.begin(), order.end(), 0);
  if (options_.rule == WordRule::kGreedy) {
    // Largest ND first. Equal NDs are ordered by descriptor value so that the result does not
    // depend on the order of features inside the image.
    const float inf = std::numeric_limits<float>::infinity();
    auto nd = [&](int i) { return best[i].empty() ? inf : best[i][0].dist2; };
    std::sort(order.begin(), order.end(), [&](int a, int b) {
      if (nd(a) != nd(b)) return nd(a) > nd(b);
      const float* ra = row(a);
      const float* rb = row(b);
      for (int d = 0; d < dim_; ++d) {
        if (ra[d] != rb[d]) return ra[d] < rb[d];
      }
      return a < b;
    });
  }

  std::vector<int> created_rows;  // rows that became words, in creation order
  for (int i : order) {
    std::vector<Neighbor>& top = best[i];
    for (std::size_t w = 0; w < created_rows.size(); ++w) {
      const float bound = top.size() < 2 ? std::numeric_limits<float>::infinity() : top[1].dist2;
      const float d2 = squaredDistanceBelow(row(i), row(created_rows[w]), dim_, bound);
      if (d2 <= bound) offerNeighbor(&top, 2, {d2, q.created_words[w]});
    }
    if (decideNewWord(top)) {
      q.word_of_feature[i] = next_word_id_++;
      q.created_words.push_back(q.word_of_feature[i]);
      created_rows.push_back(i);
    } else {
      q.word_of_feature[i] = top[0].id;
      q.distance_of_feature[i] = std::sqrt(top[0].dist2);
    }
  }
  std::vector<std::uint32_t> slots(created_rows.size());
  for (std::size_t w = 0; w < created_rows.size(); ++w)
    slots[w] = storeWord(q.created_words[w], frame_id, row(created_rows[w]));
  forest_->insert(slots.data(), slots.size());
  double sum = 0;
  for (float d : q.distance_of_feature) sum += d;
  q.mean_error = sum / m;
  return q;
}

void Vocabulary::insert(const std::vector<std::int64_t>& ids, const cv::Mat& descriptors,
                        const std::vector<std::int64_t>& created_frames) {
  checkDescriptors(descriptors, "insert");
  require(std::size_t(descriptors.rows) == ids.size() && created_frames.size() == ids.size(),
          "insert: ids, descriptors and created frames differ in count");
  for (std::int64_t id : ids) {
    if (id < 0) fail("insert: negative word id " + std::to_string(id));
    if (contains(id)) fail("insert: word " + std::to_string(id) + " is already in RAM");
  }
  // Retrievals hand their ids sorted; other callers pay for a sorted copy.
  std::vector<std::int64_t> copy;
  const std::vector<std::int64_t>* sorted = &ids;
  if (!std::is_sorted(ids.begin(), ids.end())) {
    copy = ids;
    std::sort(copy.begin(), copy.end());
    sorted = &copy;
  }
  const auto twice = std::adjacent_find(sorted->begin(), sorted->end());
  if (twice != sorted->end()) fail("insert: word " + std::to_string(*twice) + " given twice");
  touched_ = true;
  const cv::Mat rows = descriptors.isContinuous() ? descriptors : descriptors.clone();
  std::vector<std::uint32_t> slots(ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) {
    slots[i] = storeWord(ids[i], created_frames[i], rows.ptr<float>(int(i)));
    next_word_id_ = std::max(next_word_id_, ids[i] + 1);
  }
  forest_->insert(slots.data(), slots.size());
}

void Vocabulary::continueAt(std::int64_t next_word_id) {
  require(next_word_id >= 0, "continueAt: negative word id " + std::to_string(next_word_id));
  next_word_id_ = next_word_id;
}

void Vocabulary::erase(const std::vector<std::int64_t>& ids) {
  for (std::int64_t id : ids) {
    if (!contains(id)) fail("erase: word " + std::to_string(id) + " is not in RAM");
  }
  touched_ = true;
  for (std::int64_t id : ids) {
    const std::uint32_t slot = slot_of_.find(id);
    if (slot == IdTable::kNone) continue;  // listed twice
    forest_->remove(slot);
    store_.release(slot);
    slot_of_.erase(id);
  }
}

const float* Vocabulary::descriptor(std::int64_t id) const {
  const std::uint32_t slot = contains(id) ? slot_of_.find(id) : IdTable::kNone;
  return slot == IdTable::kNone ? nullptr : store_.data(slot);
}

std::int64_t Vocabulary::createdFrame(std::int64_t id) const {
  const std::uint32_t slot = contains(id) ? slot_of_.find(id) : IdTable::kNone;
  return slot == IdTable::kNone ? -1 : store_.createdFrame(slot);
}

std::vector<std::int64_t> Vocabulary::ids() const { return slot_of_.ids(); }

void Vocabulary::setChecks(int checks) {
  VocabularyOptions changed = options_;
  changed.checks = checks;
  changed.validate();
  options_ = changed;
}

std::vector<std::pair<std::int64_t, float>> Vocabulary::knn(const float* query, int k) const {
  require(k >= 0, "knn: k must be >= 0");
  std::vector<Neighbor> best;
  forest_->search(query, std::size_t(k), options_.checks, &best);
  std::vector<std::pair<std::int64_t, float>> out;
  out.reserve(best.size());
  for (const Neighbor& n : best) out.emplace_back(n.id, std::sqrt(n.dist2));
  return out;
}

IndexState Vocabulary::state() const {
  IndexState s;
  s.dim = dim_;
  s.kd_trees = options_.kd_trees;
  s.leaf_size = options_.leaf_size;
  s.seed = options_.seed;
  s.next_word_id = next_word_id_;
  s.nodes = forest_->internalNodes();
  return s;
}

void Vocabulary::restore(const IndexState& state, const std::vector<std::int64_t>& ids,
                         const cv::Mat& descriptors,
                         const std::vector<std::int64_t>& created_frames) {
  checkDescriptors(descriptors, "restore");
  require(std::size_t(descriptors.rows) == ids.size() && created_frames.size() == ids.size(),
          "restore: ids, descriptors and created frames differ in count");
  const cv::Mat rows = descriptors.isContinuous() ? descriptors : descriptors.clone();
  restore(state, ids, [&](std::size_t begin, std::size_t count, float* out, std::int64_t* created) {
    const float* from = rows.ptr<float>(static_cast<int>(begin));
    std::copy(from, from + count * std::size_t(dim_), out);
    std::copy(created_frames.begin() + std::ptrdiff_t(begin),
              created_frames.begin() + std::ptrdiff_t(begin + count), created);
  });
}

void Vocabulary::restore(const IndexState& state, const std::vector<std::int64_t>& ids,
                         const DescriptorLoader& load) {
  require(!touched_, "restore: the vocabulary has already been used");
  require(state.dim == dim_ && state.kd_trees == options_.kd_trees &&
              state.leaf_size == options_.leaf_size && state.seed == options_.seed,
          "restore: the state was made with other index settings (dim " +
              std::to_string(state.dim) + ", trees " + std::to_string(state.kd_trees) + ", leaf " +
              std::to_string(state.leaf_size) + ")");
  const bool legacy = state.nodes.empty() && !state.legacy_splits.empty();
  if (legacy) {
    forest_->replaySplits(state.legacy_splits);
  } else {
    require(state.legacy_splits.empty(), "restore: the state holds both nodes and a split log");
    forest_->loadNodes(state.nodes);
  }
  touched_ = true;
  std::int64_t max_id = -1;
  std::vector<std::uint32_t> slots;
  slots.reserve(ids.size());
  std::vector<std::int64_t> created;
  // Descriptors go straight into the store, a chunk's run at a time (a staging matrix would
  // touch, and fault in, as much memory again), and each run goes down the trees on other
  // threads while the next one loads.
  store_.reserve(ids.size());
  forest_->reserveSlots(store_.slotCount() + ids.size());
  KdForest::BackgroundFill fill(forest_.get());
  for (std::size_t begin = 0; begin < ids.size();) {
    const std::size_t count = std::min(ids.size() - begin, store_.runRoom());
    const std::uint32_t first = store_.appendRun(count);
    created.assign(count, -1);
    load(begin, count, store_.mutableData(first), created.data());
    for (std::size_t k = 0; k < count; ++k) {
      const std::int64_t id = ids[begin + k];
      if (id < 0 || contains(id))
        fail("restore: word " + std::to_string(id) + " negative or given twice");
      const auto slot = static_cast<std::uint32_t>(first + k);
      store_.setRecord(slot, id, created[k]);
      slot_of_.set(id, slot);
      slots.push_back(slot);
      max_id = std::max(max_id, id);
    }
    fill.add(slots.data() + begin, count);
    begin += count;
  }
  fill.finish();
  if (legacy) forest_->collapseEmpty();
  require(max_id < state.next_word_id, "restore: a word id is beyond the state's next word id");
  next_word_id_ = state.next_word_id;
}

}  // namespace placedb::vocab
