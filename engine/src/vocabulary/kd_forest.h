#pragma once
// A randomized kd-forest (Silpa-Anan & Hartley, as in FLANN's KDTreeIndex) that grows one point at
// a time and whose shape is a pure function of the sequence of insert/remove calls.
//
// Why not flann::KDTreeIndex: FLANN 1.9.2 shuffles the points of every tree with
// std::random_device (kdtree_index.h, buildIndexImpl), so two builds over the same words give
// different trees and different approximate answers; and its addPoints() either rebuilds the whole
// index (a long stall) or hangs single points under leaves. This forest keeps FLANN's search
// (best-bin-first over all trees sharing one check budget, split on one of the 5 highest-variance
// dimensions chosen at random, at the mean) but grows by splitting a leaf bucket when it overflows,
// with the random choice drawn from a hash of (seed, tree, node). Nothing is ever rebuilt, so no
// call costs more than routing its points down the trees.
//
// Persisting the forest only needs its split log (append-only) and the set of live points:
// replaySplits() + insertAllWithoutSplitting() of the live points rebuild the same trees with the
// same bucket contents. Search results never depend on the order inside a bucket (whole buckets
// are examined; ties on distance go to the smaller word id).
#include <cstdint>
#include <vector>

#include "vocabulary/slot_store.h"

namespace placedb::vocab {

struct SplitRecord {
  std::uint8_t tree = 0;
  std::uint32_t node = 0;  // the leaf that became internal; its children get the next two ids
  std::uint16_t dim = 0;
  float value = 0;  // points with v[dim] < value go left
  bool operator==(const SplitRecord& o) const {
    return tree == o.tree && node == o.node && dim == o.dim && value == o.value;
  }
};

struct Neighbor {
  float dist2 = 0;  // squared Euclidean distance
  std::int64_t id = -1;
  bool operator<(const Neighbor& o) const {
    return dist2 < o.dist2 || (dist2 == o.dist2 && id < o.id);
  }
};

// Keeps the k best neighbours under Neighbor::operator< (sorted, best first).
void offerNeighbor(std::vector<Neighbor>* best, std::size_t k, Neighbor candidate);

float squaredDistance(const float* a, const float* b, int dim);

class KdForest {
 public:
  KdForest(const SlotStore* store, int trees, int leaf_size, std::uint64_t seed);

  void insert(std::uint32_t slot);
  // Used by restore: the split log already holds every split the live points caused, so the
  // points only go to their buckets, in the given order. Trees fill in parallel.
  void insertAllWithoutSplitting(const std::vector<std::uint32_t>& slots);
  // The slot's descriptor must still be in the store: removal routes it to its bucket.
  void remove(std::uint32_t slot);

  // Best-bin-first: examines whole buckets until at least `checks` distinct points were compared
  // and k neighbours are known, never visiting a branch whose bound exceeds the k-th distance.
  void search(const float* query, std::size_t k, int checks, std::vector<Neighbor>* out) const;

  const std::vector<SplitRecord>& splits() const { return splits_; }
  // Only on a fresh forest; throws placedb::Error(kInvalidArgument) on a log that does not fit.
  void replaySplits(const std::vector<SplitRecord>& log);

  int trees() const { return static_cast<int>(trees_.size()); }

 private:
  struct Node {
    std::int32_t left = -1;  // -1: leaf
    std::int32_t right = -1;
    std::uint16_t dim = 0;
    float value = 0;
    std::vector<std::uint32_t> bucket;  // slots, leaves only
  };
  struct Tree {
    std::vector<Node> nodes;
  };
  struct Branch {
    float bound;
    std::uint32_t tree;
    std::int32_t node;
    bool operator>(const Branch& o) const {
      if (bound != o.bound) return bound > o.bound;
      if (tree != o.tree) return tree > o.tree;
      return node > o.node;
    }
  };

  std::int32_t leafOf(const Tree& tree, const float* v) const;
  void trySplit(std::uint32_t tree_index, std::int32_t node_index);
  void applySplit(std::uint32_t tree_index, std::int32_t node_index, std::uint16_t dim,
                  float value);

  const SlotStore* store_;
  int dim_;
  int leaf_size_;
  std::uint64_t seed_;
  std::vector<Tree> trees_;
  std::vector<SplitRecord> splits_;
  // Per-query "already compared" marks; a counter avoids clearing them between queries.
  mutable std::vector<std::uint32_t> seen_;
  mutable std::uint32_t query_stamp_ = 0;
};

}  // namespace placedb::vocab
