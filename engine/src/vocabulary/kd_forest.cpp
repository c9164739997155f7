#include "vocabulary/kd_forest.h"

#include <algorithm>
#include <array>
#include <limits>
#include <queue>
#include <string>
#include <thread>

#include "placedb/error.h"

namespace placedb::vocab {

namespace {

// FLANN's choices: split among the 5 highest-variance dimensions, estimate from at most 100 points.
constexpr int kTopDims = 5;

std::uint64_t splitMix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

}  // namespace

float squaredDistance(const float* a, const float* b, int dim) {
  // No bound stops it early: the same sums, in the same order, as every bounded comparison.
  return squaredDistanceBelow(a, b, dim, std::numeric_limits<float>::infinity());
}

void offerNeighbor(std::vector<Neighbor>* best, std::size_t k, Neighbor candidate) {
  if (k == 0) return;
  if (best->size() == k && !(candidate < best->back())) return;
  auto at = std::upper_bound(best->begin(), best->end(), candidate);
  best->insert(at, candidate);
  if (best->size() > k) best->pop_back();
}

KdForest::KdForest(const SlotStore* store, int trees, int leaf_size, std::uint64_t seed)
    : store_(store), dim_(store->dim()), leaf_size_(leaf_size), seed_(seed), trees_(trees) {
  for (auto& tree : trees_) {  // every tree starts as one empty leaf
    tree.nodes.emplace_back();
    tree.buckets.emplace_back();
    tree.parent.push_back(-1);
  }
}

std::int32_t KdForest::leafOf(const Tree& tree, const float* v) const {
  std::int32_t node = 0;
  while (tree.nodes[node].left >= 0) {
    const Node& n = tree.nodes[node];
    node = v[n.dim] < n.value ? n.left : n.right;
  }
  return node;
}

void KdForest::placeInLeaf(Tree& tree, std::uint32_t slot, std::int32_t leaf) {
  tree.buckets[static_cast<std::size_t>(leaf)].push_back(slot);
  tree.leaf_of[slot] = leaf;
}

void KdForest::reserveSlots(std::size_t slots) {
  for (Tree& tree : trees_)
    if (tree.leaf_of.size() < slots) tree.leaf_of.resize(slots, -1);
}

void KdForest::insert(std::uint32_t slot) { insert(&slot, 1); }

void KdForest::insert(const std::uint32_t* slots, std::size_t count) {
  if (count == 0) return;
  reserveSlots(std::size_t(*std::max_element(slots, slots + count)) + 1);
  // Tree by tree: the trees share nothing, so this is the order of one slot at a time. The leaves
  // are found for all slots first, several descents side by side (leavesOf); a leaf that a slot
  // before this one split since is then descended further, as the splits only ever turned leaves
  // into internal nodes.
  std::vector<std::int32_t> leaves(count);
  for (std::uint32_t t = 0; t < trees_.size(); ++t) {
    Tree& tree = trees_[t];
    leavesOf(tree, slots, count, leaves.data());
    for (std::size_t i = 0; i < count; ++i) {
      const float* v = store_->data(slots[i]);
      std::int32_t leaf = leaves[i];
      while (tree.nodes[static_cast<std::size_t>(leaf)].left >= 0) {
        const Node& n = tree.nodes[static_cast<std::size_t>(leaf)];
        leaf = v[n.dim] < n.value ? n.left : n.right;
      }
      placeInLeaf(tree, slots[i], leaf);
      if (tree.buckets[static_cast<std::size_t>(leaf)].size() > std::size_t(leaf_size_))
        trySplit(t, leaf);
    }
  }
}

void KdForest::leavesOf(const Tree& tree, const std::uint32_t* slots, std::size_t count,
                        std::int32_t* leaves) const {
  // Each descent waits on one node at a time: kGroup of them in turn keep as many loads in
  // flight, each step asking for the node the next one reads.
  constexpr std::size_t kGroup = 8;
  for (std::size_t first = 0; first < count; first += kGroup) {
    const std::size_t n = std::min(kGroup, count - first);
    const float* v[kGroup];
    for (std::size_t j = 0; j < n; ++j) {
      v[j] = store_->data(slots[first + j]);
      leaves[first + j] = 0;
    }
    for (bool moved = true; moved;) {
      moved = false;
      for (std::size_t j = 0; j < n; ++j) {
        std::int32_t& node = leaves[first + j];
        const Node& at = tree.nodes[static_cast<std::size_t>(node)];
        if (at.left < 0) continue;
        node = v[j][at.dim] < at.value ? at.left : at.right;
        __builtin_prefetch(&tree.nodes[static_cast<std::size_t>(node)]);
        moved = true;
      }
    }
  }
}

KdForest::BackgroundFill::BackgroundFill(KdForest* forest) : forest_(forest) {
  const std::size_t trees = forest->trees_.size();
  const std::size_t workers =
      std::min<std::size_t>(trees, std::max(1u, std::thread::hardware_concurrency()));
  for (std::size_t w = 0; w < workers; ++w)
    threads_.emplace_back([this, w, workers] { work(w, workers); });
}

void KdForest::BackgroundFill::add(const std::uint32_t* slots, std::size_t count) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    runs_.emplace_back(slots, slots + count);
  }
  ready_.notify_all();
}

void KdForest::BackgroundFill::finish() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (closed_ && threads_.empty()) return;
    closed_ = true;
  }
  ready_.notify_all();
  for (auto& thread : threads_) thread.join();
  threads_.clear();
}

void KdForest::BackgroundFill::work(std::size_t first_tree, std::size_t stride) {
  for (std::size_t next = 0;; ++next) {
    const std::vector<std::uint32_t>* run = nullptr;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      ready_.wait(lock, [&] { return next < runs_.size() || closed_; });
      if (next >= runs_.size()) return;  // closed and every run done
      run = &runs_[next];
    }
    for (std::size_t t = first_tree; t < forest_->trees_.size(); t += stride) {
      Tree& tree = forest_->trees_[t];
      for (std::uint32_t slot : *run)
        placeInLeaf(tree, slot, forest_->leafOf(tree, forest_->store_->data(slot)));
    }
  }
}

void KdForest::remove(std::uint32_t slot) {
  for (std::uint32_t t = 0; t < trees_.size(); ++t) {
    Tree& tree = trees_[t];
    const std::int32_t node = slot < tree.leaf_of.size() ? tree.leaf_of[slot] : -1;
    auto* bucket = node >= 0 ? &tree.buckets[static_cast<std::size_t>(node)] : nullptr;
    auto it = bucket ? std::find(bucket->begin(), bucket->end(), slot)
                     : std::vector<std::uint32_t>::iterator();
    if (!bucket || it == bucket->end()) {
      throw Error(ErrorCode::kInternal, "kd-forest: removed point is not in its bucket");
    }
    *it = bucket->back();
    bucket->pop_back();
    tree.leaf_of[slot] = -1;
    // An empty leaf would keep its split forever: the trees would grow with every word ever
    // inserted, not with the live ones.
    const std::int32_t parent = tree.parent[static_cast<std::size_t>(node)];
    if (bucket->empty() && parent >= 0) spliceOut(t, parent, node);
  }
}

std::int32_t KdForest::allocate(Tree& tree) {
  if (!tree.free.empty()) {
    const std::int32_t id = tree.free.top();
    tree.free.pop();
    tree.nodes[static_cast<std::size_t>(id)] = Node{};
    tree.buckets[static_cast<std::size_t>(id)].clear();
    return id;
  }
  tree.nodes.emplace_back();
  tree.buckets.emplace_back();
  tree.parent.push_back(-1);
  return static_cast<std::int32_t>(tree.nodes.size() - 1);
}

void KdForest::release(Tree& tree, std::int32_t node) {
  Node& n = tree.nodes[static_cast<std::size_t>(node)];
  n = Node{};
  n.left = kFree;
  std::vector<std::uint32_t>().swap(tree.buckets[static_cast<std::size_t>(node)]);
  tree.parent[static_cast<std::size_t>(node)] = -1;
  tree.free.push(node);
}

void KdForest::markChanged(Tree& tree, std::int32_t node) {
  if (changed_all_) return;
  tree.changed.push_back(node);
  // Nobody took the changes for a long while (a vocabulary used without persistence): keep the
  // list as long as the tree at most.
  if (tree.changed.size() > 2 * tree.nodes.size() + 1024) {
    std::sort(tree.changed.begin(), tree.changed.end());
    tree.changed.erase(std::unique(tree.changed.begin(), tree.changed.end()), tree.changed.end());
  }
}

void KdForest::spliceOut(std::uint32_t tree_index, std::int32_t parent, std::int32_t child) {
  Tree& tree = trees_[tree_index];
  const std::int32_t sibling =
      tree.nodes[parent].left == child ? tree.nodes[parent].right : tree.nodes[parent].left;
  tree.nodes[parent] = tree.nodes[sibling];
  tree.buckets[parent].swap(tree.buckets[sibling]);
  // What hung from the sibling now hangs from the parent's id.
  if (tree.nodes[parent].left >= 0) {
    tree.parent[static_cast<std::size_t>(tree.nodes[parent].left)] = parent;
    tree.parent[static_cast<std::size_t>(tree.nodes[parent].right)] = parent;
  } else {
    for (std::uint32_t slot : tree.buckets[parent]) tree.leaf_of[slot] = parent;
  }
  release(tree, child);
  release(tree, sibling);
  markChanged(tree, parent);
  markChanged(tree, sibling);  // its stored row, if it was internal, must go
}

void KdForest::trySplit(std::uint32_t tree_index, std::int32_t node_index) {
  // Sort by word id so that the float sums below do not depend on the bucket's history.
  std::vector<std::uint32_t> points = trees_[tree_index].buckets[node_index];
  std::sort(points.begin(), points.end(),
            [&](std::uint32_t a, std::uint32_t b) { return store_->id(a) < store_->id(b); });
  const std::size_t n = points.size();
  std::vector<double> mean(dim_, 0.0), var(dim_, 0.0);
  for (std::uint32_t p : points) {
    const float* v = store_->data(p);
    for (int d = 0; d < dim_; ++d) mean[d] += v[d];
  }
  for (int d = 0; d < dim_; ++d) mean[d] /= double(n);
  for (std::uint32_t p : points) {
    const float* v = store_->data(p);
    for (int d = 0; d < dim_; ++d) var[d] += (v[d] - mean[d]) * (v[d] - mean[d]);
  }
  std::vector<int> order(dim_);
  for (int d = 0; d < dim_; ++d) order[d] = d;
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return var[a] > var[b]; });
  int candidates = 0;
  while (candidates < kTopDims && candidates < dim_ && var[order[candidates]] > 0) ++candidates;
  if (candidates == 0) return;  // identical points: keep the bucket whole
  const std::uint64_t draw =
      splitMix64(seed_ ^ splitMix64((std::uint64_t(tree_index) << 32) | std::uint32_t(node_index)));
  const int dim = order[draw % std::uint64_t(candidates)];
  const float value = static_cast<float>(mean[dim]);
  std::size_t left = 0;
  for (std::uint32_t p : points) left += store_->data(p)[dim] < value ? 1 : 0;
  if (left == 0 || left == n) return;  // rounding put every point on one side
  applySplit(tree_index, node_index, static_cast<std::uint16_t>(dim), value);
}

void KdForest::applySplit(std::uint32_t tree_index, std::int32_t node_index, std::uint16_t dim,
                          float value) {
  Tree& tree = trees_[tree_index];
  const std::int32_t left = allocate(tree);
  const std::int32_t right = allocate(tree);
  Node& node = tree.nodes[node_index];
  std::vector<std::uint32_t> bucket;
  bucket.swap(tree.buckets[node_index]);
  node.left = left;
  node.right = right;
  node.dim = dim;
  node.value = value;
  tree.parent[static_cast<std::size_t>(left)] = node_index;
  tree.parent[static_cast<std::size_t>(right)] = node_index;
  for (std::uint32_t p : bucket) placeInLeaf(tree, p, store_->data(p)[dim] < value ? left : right);
  markChanged(tree, node_index);
}

}  // namespace placedb::vocab
