// The kd-forest's best-bin-first search. A search waits on memory at every step: the next node of
// a descent, a bucket's slots, their descriptors. Searching several queries at once, one step of
// each in turn, lets each step's loads arrive while the other searches work; every search still
// takes its own steps in the order a lone search takes them, so it finds the same neighbours.
#include <algorithm>
#include <functional>
#include <limits>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "vocabulary/kd_forest.h"

namespace placedb::vocab {

namespace {

constexpr std::size_t kLineFloats = 64 / sizeof(float);
// Room for the branches a search queues, so that the queue rarely grows during a search.
constexpr std::size_t kBranchesReserved = 128;

// The points one search has compared: a small open-addressing set, so that searches keep no
// state in the forest (several threads may search at once) and the marks stay in L1 cache.
class VisitedSlots {
 public:
  VisitedSlots() : keys_(kInitial, 0), mask_(kInitial - 1) {}
  // True when `slot` was not in the set (it is now).
  bool insert(std::uint32_t slot) {
    if (2 * (count_ + 1) > keys_.size()) grow();
    return place(slot + 1);
  }

 private:
  static constexpr std::size_t kInitial = 256;
  std::size_t home(std::uint32_t key) const { return (key * 2654435761u) & mask_; }
  bool place(std::uint32_t key) {
    for (std::size_t i = home(key);; i = (i + 1) & mask_) {
      if (keys_[i] == key) return false;
      if (keys_[i] == 0) {
        keys_[i] = key;
        ++count_;
        return true;
      }
    }
  }
  void grow() {
    std::vector<std::uint32_t> old(keys_.size() * 2, 0);
    old.swap(keys_);
    mask_ = keys_.size() - 1;
    count_ = 0;
    for (std::uint32_t key : old)
      if (key != 0) place(key);
  }
  std::vector<std::uint32_t> keys_;
  std::size_t mask_;
  std::size_t count_ = 0;
};

}  // namespace

// One search's state between its steps.
struct KdForest::Walk {
  enum class Step { kNode, kSlots, kDescriptors, kDistances, kDone };
  const float* query = nullptr;
  std::vector<Neighbor>* out = nullptr;
  std::vector<Branch> branches;  // a heap, smallest first
  VisitedSlots visited;
  int compared = 0;
  std::uint32_t next_tree = 0;  // trees not descended from their root yet
  std::uint32_t tree = 0;       // the current descent
  std::int32_t node = 0;
  float bound = 0;
  const std::vector<std::uint32_t>* bucket = nullptr;
  Step step = Step::kDone;
};

float squaredDistanceBelow(const float* a, const float* b, int dim, float bound) {
  // Four partial sums let the compiler vectorise; their order is fixed, so results are identical
  // on every run of the same binary. The total is checked every 16 dimensions: every partial
  // sum is non-negative and float addition is monotone, so once the partial total exceeds the
  // bound the full one does too, and stopping changes no comparison against the bound.
#if defined(__SSE2__)
  if (dim % 16 == 0) {
    // The loop below, written out: lane j of `sum` is s_j, and (s0 + s1) + (s2 + s3) is formed
    // in that order, so both give the same bits.
    __m128 sum = _mm_setzero_ps();
    const auto total = [&sum] {
      const __m128 pairs = _mm_add_ps(sum, _mm_shuffle_ps(sum, sum, _MM_SHUFFLE(2, 3, 0, 1)));
      return _mm_cvtss_f32(_mm_add_ss(pairs, _mm_movehl_ps(pairs, pairs)));
    };
    for (int i = 0; i < dim; i += 16) {
      for (int j = i; j < i + 16; j += 4) {
        const __m128 d = _mm_sub_ps(_mm_loadu_ps(a + j), _mm_loadu_ps(b + j));
        sum = _mm_add_ps(sum, _mm_mul_ps(d, d));
      }
      if (i + 16 < dim) {
        const float partial = total();
        if (partial > bound) return partial;
      }
    }
    return total();
  }
#endif
  float s0 = 0, s1 = 0, s2 = 0, s3 = 0;
  int i = 0;
  while (i + 4 <= dim) {
    const int block_end = std::min(dim - (dim - i) % 4, i + 16);
    for (; i < block_end; i += 4) {
      const float d0 = a[i] - b[i], d1 = a[i + 1] - b[i + 1];
      const float d2 = a[i + 2] - b[i + 2], d3 = a[i + 3] - b[i + 3];
      s0 += d0 * d0;
      s1 += d1 * d1;
      s2 += d2 * d2;
      s3 += d3 * d3;
    }
    if (i + 4 <= dim && (s0 + s1) + (s2 + s3) > bound) return (s0 + s1) + (s2 + s3);
  }
  for (; i < dim; ++i) {
    const float d = a[i] - b[i];
    s0 += d * d;
  }
  return (s0 + s1) + (s2 + s3);
}

namespace {

float worstOf(const std::vector<Neighbor>& out, std::size_t k) {
  return out.size() < k ? std::numeric_limits<float>::infinity() : out.back().dist2;
}

}  // namespace

void KdForest::search(const float* query, std::size_t k, int checks,
                      std::vector<Neighbor>* out) const {
  search(&query, &out, 1, k, checks);
}

void KdForest::search(const float* const* queries, std::vector<Neighbor>* const* outs,
                      std::size_t count, std::size_t k, int checks) const {
  std::vector<Walk> walks(count);
  std::size_t live = 0;
  for (std::size_t i = 0; i < count; ++i) {
    Walk& w = walks[i];
    w.query = queries[i];
    w.out = outs[i];
    w.out->clear();
    if (k == 0 || trees_.empty()) continue;
    w.branches.reserve(kBranchesReserved);
    w.next_tree = 1;
    w.step = Walk::Step::kNode;
    ++live;
  }
  while (live > 0) {
    for (Walk& w : walks) {
      if (w.step == Walk::Step::kDone) continue;
      advance(w, k, checks);
      if (w.step == Walk::Step::kDone) --live;
    }
  }
}

void KdForest::advance(Walk& w, std::size_t k, int checks) const {
  const Tree& tree = trees_[w.tree];
  switch (w.step) {
    case Walk::Step::kNode: {
      // One node down, queueing the far side of its split.
      const Node& n = tree.nodes[static_cast<std::size_t>(w.node)];
      if (n.left < 0) {
        w.bucket = &tree.buckets[static_cast<std::size_t>(w.node)];
        __builtin_prefetch(w.bucket);
        w.step = Walk::Step::kSlots;
        return;
      }
      const float diff = w.query[n.dim] - n.value;
      const std::int32_t near_child = diff < 0 ? n.left : n.right;
      const std::int32_t far_child = diff < 0 ? n.right : n.left;
      const float far_bound = w.bound + diff * diff;
      if (far_bound <= worstOf(*w.out, k)) {
        w.branches.push_back({far_bound, w.tree, far_child});
        std::push_heap(w.branches.begin(), w.branches.end(), std::greater<Branch>());
      }
      w.node = near_child;
      __builtin_prefetch(&tree.nodes[static_cast<std::size_t>(near_child)]);
      return;
    }
    case Walk::Step::kSlots:
      if (!w.bucket->empty()) __builtin_prefetch(w.bucket->data());
      w.step = Walk::Step::kDescriptors;
      return;
    case Walk::Step::kDescriptors:
      // The bucket's descriptors are scattered over the store: asking for all of them before the
      // first is needed overlaps their cache misses.
      for (std::uint32_t slot : *w.bucket) {
        const float* v = store_->data(slot);
        for (std::size_t f = 0; f < std::size_t(dim_); f += kLineFloats) __builtin_prefetch(v + f);
      }
      w.step = Walk::Step::kDistances;
      return;
    case Walk::Step::kDistances:
      for (std::uint32_t slot : *w.bucket) {
        if (!w.visited.insert(slot)) continue;
        ++w.compared;
        const float bound_now = worstOf(*w.out, k);
        const float d2 = squaredDistanceBelow(w.query, store_->data(slot), dim_, bound_now);
        if (d2 <= bound_now) offerNeighbor(w.out, k, {d2, store_->id(slot)});
      }
      w.step = nextDescent(w, k, checks) ? Walk::Step::kNode : Walk::Step::kDone;
      return;
    case Walk::Step::kDone:
      return;
  }
}

bool KdForest::nextDescent(Walk& w, std::size_t k, int checks) const {
  // Every tree from its root first, then the closest queued branch while checks remain.
  if (w.next_tree < trees_.size()) {
    w.tree = w.next_tree++;
    w.node = 0;
    w.bound = 0;
    return true;
  }
  while (!w.branches.empty() && (w.compared < checks || w.out->size() < k)) {
    std::pop_heap(w.branches.begin(), w.branches.end(), std::greater<Branch>());
    const Branch b = w.branches.back();
    w.branches.pop_back();
    if (b.bound > worstOf(*w.out, k)) continue;
    w.tree = b.tree;
    w.node = b.node;
    w.bound = b.bound;
    __builtin_prefetch(&trees_[b.tree].nodes[static_cast<std::size_t>(b.node)]);
    return true;
  }
  return false;
}

}  // namespace placedb::vocab
