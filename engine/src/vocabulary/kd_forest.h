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
// Removing a point that empties its bucket splices the bucket's parent out (the sibling takes the
// parent's place), so every leaf but an empty root holds a point: the trees' size follows the live
// points, not every word ever inserted, and freed nodes are reused lowest index first.
//
// Persisting the forest needs its internal nodes (ForestNode) and the set of live points:
// loadNodes() + a BackgroundFill of the live points rebuild the same trees with the same bucket
// contents and the same free nodes. takeChanges() hands out only the nodes that
// changed since the last call, so an engine can update its stored copy per frame. Search results
// never depend on the order inside a bucket (whole buckets are examined; ties on distance go to
// the smaller word id).
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <queue>
#include <thread>
#include <utility>
#include <vector>

#include "vocabulary/slot_store.h"

namespace placedb::vocab {

// A split as maps of schema 2 logged them: the leaf `node` became internal and its children got
// the next two node ids. Read only to convert such maps.
struct SplitRecord {
  std::uint8_t tree = 0;
  std::uint32_t node = 0;
  std::uint16_t dim = 0;
  float value = 0;  // points with v[dim] < value go left
  bool operator==(const SplitRecord& o) const {
    return tree == o.tree && node == o.node && dim == o.dim && value == o.value;
  }
};

// An internal node of one tree. Nodes that are not internal are leaves when a parent names them
// (or the root, node 0) and free otherwise.
struct ForestNode {
  std::uint8_t tree = 0;
  std::uint32_t node = 0;
  std::uint32_t left = 0;
  std::uint32_t right = 0;
  std::uint16_t dim = 0;
  float value = 0;  // points with v[dim] < value go left
  bool operator==(const ForestNode& o) const {
    return tree == o.tree && node == o.node && left == o.left && right == o.right && dim == o.dim &&
           value == o.value;
  }
};

// What changed since the last KdForest::takeChanges(): internal nodes to write and node ids whose
// stored row must go; `full` asks for the stored copy to be replaced by `upserts` alone.
struct ForestChanges {
  bool full = false;
  std::vector<ForestNode> upserts;
  std::vector<std::pair<std::uint8_t, std::uint32_t>> deletions;  // (tree, node)
  bool empty() const { return !full && upserts.empty() && deletions.empty(); }
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
// squaredDistance(a, b, dim) when it is at most `bound`; otherwise some value above `bound`
// (the sum so far), found without summing every dimension.
float squaredDistanceBelow(const float* a, const float* b, int dim, float bound);

class KdForest {
 public:
  KdForest(const SlotStore* store, int trees, int leaf_size, std::uint64_t seed);

  void insert(std::uint32_t slot);
  // insert() of each slot in turn, with their descents side by side.
  void insert(const std::uint32_t* slots, std::size_t count);
  // Room for slots [0, slots) before a BackgroundFill, whose threads must not grow the tables.
  void reserveSlots(std::size_t slots);
  // Used by restore, fed run by run while the caller still loads descriptors: the loaded nodes
  // already hold every split the live points caused, so the points only go to their buckets,
  // without splitting. Runs go down the trees on background threads, each tree taking them in
  // the order added. The store must not move the descriptors of added slots (SlotStore chunks do
  // not move). finish() waits for the threads.
  class BackgroundFill {
   public:
    explicit BackgroundFill(KdForest* forest);
    ~BackgroundFill() { finish(); }
    BackgroundFill(const BackgroundFill&) = delete;
    BackgroundFill& operator=(const BackgroundFill&) = delete;
    void add(const std::uint32_t* slots, std::size_t count);
    void finish();

   private:
    void work(std::size_t first_tree, std::size_t stride);

    KdForest* forest_;
    std::mutex mutex_;
    std::condition_variable ready_;
    std::deque<std::vector<std::uint32_t>> runs_;  // a deque: adding never moves earlier runs
    bool closed_ = false;
    std::vector<std::thread> threads_;
  };
  // The slot's descriptor must still be in the store: removal routes it to its bucket.
  void remove(std::uint32_t slot);

  // Best-bin-first: examines whole buckets until at least `checks` distinct points were compared
  // and k neighbours are known, never visiting a branch whose bound exceeds the k-th distance.
  // Safe to call from several threads at once while nothing modifies the forest.
  void search(const float* query, std::size_t k, int checks, std::vector<Neighbor>* out) const;
  // search() of `count` queries at once, outs[i] for queries[i]: one step of each in turn, so
  // that each one's memory loads overlap the others' work. Each result is what search() gives.
  void search(const float* const* queries, std::vector<Neighbor>* const* outs, std::size_t count,
              std::size_t k, int checks) const;

  // Every internal node, by tree then node id.
  std::vector<ForestNode> internalNodes() const;
  void takeChanges(ForestChanges* out);
  // Only on a fresh forest; throws placedb::Error(kInvalidArgument) on nodes that do not form
  // trees (a child out of range or named twice, a node no path reaches, a bad dimension).
  void loadNodes(const std::vector<ForestNode>& nodes);

  // Converting a schema-2 map: replay its split log on a fresh forest, insert the live points
  // without splitting, then collapseEmpty() splices out every subtree left without a point and
  // marks the whole forest changed (ForestChanges::full).
  void replaySplits(const std::vector<SplitRecord>& log);
  void collapseEmpty();

  int trees() const { return static_cast<int>(trees_.size()); }
  std::size_t nodeCount() const;  // allocated nodes of all trees, internal, leaf and free

 private:
  static constexpr std::int32_t kLeaf = -1;
  static constexpr std::int32_t kFree = -2;
  // 16 bytes, four to a cache line: a search is bound by the loads of the nodes it descends,
  // so the buckets live in their own array beside the nodes.
  struct Node {
    std::int32_t left = kLeaf;  // or kFree
    std::int32_t right = -1;
    std::uint16_t dim = 0;
    float value = 0;
  };
  struct Tree {
    std::vector<Node> nodes;
    std::vector<std::vector<std::uint32_t>> buckets;  // slots of leaf nodes[i], by node id
    // Removal finds a point's leaf and the leaf's parent here instead of descending the tree
    // (a frame that moves many words to LTM would pay a descent per word and tree).
    std::vector<std::int32_t> parent;   // by node id; -1 for the root and free nodes
    std::vector<std::int32_t> leaf_of;  // by slot: the leaf holding it
    // Free node ids, smallest first: the choice of id must not depend on the order of past frees,
    // or a restored forest (which only knows which ids are free) would pick other ids.
    std::priority_queue<std::int32_t, std::vector<std::int32_t>, std::greater<std::int32_t>> free;
    std::vector<std::int32_t> changed;  // node ids, unsorted, repeats allowed
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

  struct Walk;  // one search between its steps (kd_forest_search.cpp)
  void advance(Walk& walk, std::size_t k, int checks) const;
  bool nextDescent(Walk& walk, std::size_t k, int checks) const;

  std::int32_t leafOf(const Tree& tree, const float* v) const;
  // leafOf() of each slot's descriptor into leaves[i].
  void leavesOf(const Tree& tree, const std::uint32_t* slots, std::size_t count,
                std::int32_t* leaves) const;
  void trySplit(std::uint32_t tree_index, std::int32_t node_index);
  void applySplit(std::uint32_t tree_index, std::int32_t node_index, std::uint16_t dim,
                  float value);
  std::int32_t allocate(Tree& tree);
  void release(Tree& tree, std::int32_t node);
  // `child` of `parent` holds no point: the other child takes the parent's place.
  void spliceOut(std::uint32_t tree_index, std::int32_t parent, std::int32_t child);
  bool pruneEmpty(std::uint32_t tree_index, std::int32_t node);  // false: the subtree is empty
  void markChanged(Tree& tree, std::int32_t node);
  static void placeInLeaf(Tree& tree, std::uint32_t slot, std::int32_t leaf);

  const SlotStore* store_;
  int dim_;
  int leaf_size_;
  std::uint64_t seed_;
  std::vector<Tree> trees_;
  bool changed_all_ = false;
};

}  // namespace placedb::vocab
