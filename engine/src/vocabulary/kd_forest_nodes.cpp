// The kd-forest's persistent form: its internal nodes, the changes since they were last taken,
// loading them back, and the conversion of schema-2 split logs.
#include <algorithm>
#include <cmath>
#include <string>

#include "placedb/error.h"
#include "vocabulary/kd_forest.h"

namespace placedb::vocab {

namespace {

[[noreturn]] void refuse(const std::string& why) {
  throw Error(ErrorCode::kInvalidArgument, "vocabulary index state: " + why);
}

}  // namespace

std::size_t KdForest::nodeCount() const {
  std::size_t n = 0;
  for (const Tree& tree : trees_) n += tree.nodes.size();
  return n;
}

std::vector<ForestNode> KdForest::internalNodes() const {
  std::vector<ForestNode> out;
  for (std::size_t t = 0; t < trees_.size(); ++t) {
    const auto& nodes = trees_[t].nodes;
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      const Node& n = nodes[i];
      if (n.left < 0) continue;
      out.push_back({static_cast<std::uint8_t>(t), static_cast<std::uint32_t>(i),
                     static_cast<std::uint32_t>(n.left), static_cast<std::uint32_t>(n.right), n.dim,
                     n.value});
    }
  }
  return out;
}

void KdForest::takeChanges(ForestChanges* out) {
  out->full = changed_all_;
  out->upserts.clear();
  out->deletions.clear();
  if (changed_all_) {
    out->upserts = internalNodes();
    changed_all_ = false;
    for (Tree& tree : trees_) tree.changed.clear();
    return;
  }
  for (std::size_t t = 0; t < trees_.size(); ++t) {
    Tree& tree = trees_[t];
    std::sort(tree.changed.begin(), tree.changed.end());
    tree.changed.erase(std::unique(tree.changed.begin(), tree.changed.end()), tree.changed.end());
    for (std::int32_t id : tree.changed) {
      const Node& n = tree.nodes[static_cast<std::size_t>(id)];
      if (n.left >= 0) {
        out->upserts.push_back({static_cast<std::uint8_t>(t), static_cast<std::uint32_t>(id),
                                static_cast<std::uint32_t>(n.left),
                                static_cast<std::uint32_t>(n.right), n.dim, n.value});
      } else {
        out->deletions.emplace_back(static_cast<std::uint8_t>(t), static_cast<std::uint32_t>(id));
      }
    }
    tree.changed.clear();
  }
}

void KdForest::loadNodes(const std::vector<ForestNode>& nodes) {
  for (const Tree& tree : trees_) {
    if (tree.nodes.size() != 1 || tree.nodes[0].left != kLeaf || !tree.buckets[0].empty())
      refuse("nodes can only be loaded into a fresh forest");
  }
  // Size each tree to its highest node id; every id starts free.
  std::vector<std::size_t> size(trees_.size(), 1);
  for (const ForestNode& n : nodes) {
    if (n.tree >= trees_.size())
      refuse("node of tree " + std::to_string(n.tree) + " in a forest of " +
             std::to_string(trees_.size()));
    // Ids stay below 2^31 (they are int32 inside); a larger one is damage, not a big map.
    if (n.node >= (1u << 30) || n.left >= (1u << 30) || n.right >= (1u << 30))
      refuse("node id out of range in tree " + std::to_string(n.tree));
    if (n.dim >= dim_ || !std::isfinite(n.value))
      refuse("node " + std::to_string(n.node) + " of tree " + std::to_string(n.tree) +
             " splits on a bad dimension or value");
    size[n.tree] = std::max<std::size_t>(
        {size[n.tree], std::size_t(n.node) + 1, std::size_t(n.left) + 1, std::size_t(n.right) + 1});
  }
  for (std::size_t t = 0; t < trees_.size(); ++t) {
    trees_[t].nodes.assign(size[t], Node{});
    trees_[t].buckets.assign(size[t], {});
    trees_[t].parent.assign(size[t], -1);
    for (Node& n : trees_[t].nodes) n.left = kFree;
  }
  std::vector<std::size_t> internal(trees_.size(), 0);
  for (const ForestNode& n : nodes) {
    Node& node = trees_[n.tree].nodes[n.node];
    if (node.left != kFree)
      refuse("node " + std::to_string(n.node) + " of tree " + std::to_string(n.tree) + " twice");
    node.left = static_cast<std::int32_t>(n.left);
    node.right = static_cast<std::int32_t>(n.right);
    node.dim = n.dim;
    node.value = n.value;
    ++internal[n.tree];
  }
  // Walk each tree from its root: every id reached once; internal ids not reached are damage.
  for (std::size_t t = 0; t < trees_.size(); ++t) {
    Tree& tree = trees_[t];
    std::vector<char> reached(tree.nodes.size(), 0);
    std::vector<std::int32_t> stack{0};
    std::vector<std::int32_t> leaves;
    std::size_t internal_reached = 0;
    reached[0] = 1;
    while (!stack.empty()) {
      const std::int32_t id = stack.back();
      stack.pop_back();
      const Node& n = tree.nodes[static_cast<std::size_t>(id)];
      if (n.left == kFree) {  // no row: a leaf
        leaves.push_back(id);
        continue;
      }
      ++internal_reached;
      for (std::int32_t child : {n.left, n.right}) {
        if (child == 0 || reached[static_cast<std::size_t>(child)])
          refuse("node " + std::to_string(child) + " of tree " + std::to_string(t) +
                 " has two parents");
        reached[static_cast<std::size_t>(child)] = 1;
        tree.parent[static_cast<std::size_t>(child)] = id;
        stack.push_back(child);
      }
    }
    if (internal_reached != internal[t])
      refuse("tree " + std::to_string(t) + " has internal nodes its root does not reach");
    for (std::int32_t leaf : leaves) tree.nodes[static_cast<std::size_t>(leaf)].left = kLeaf;
    for (std::size_t id = 0; id < tree.nodes.size(); ++id)
      if (!reached[id]) tree.free.push(static_cast<std::int32_t>(id));
    tree.changed.clear();
  }
  changed_all_ = false;
}

void KdForest::replaySplits(const std::vector<SplitRecord>& log) {
  // Every split adds two nodes: sizing the node arrays first spares moving them as they grow.
  std::vector<std::size_t> added(trees_.size(), 0);
  for (const SplitRecord& s : log)
    if (s.tree < trees_.size()) added[s.tree] += 2;
  for (std::size_t t = 0; t < trees_.size(); ++t) {
    if (!trees_[t].free.empty()) refuse("a split log can only be replayed on a fresh forest");
    trees_[t].nodes.reserve(trees_[t].nodes.size() + added[t]);
    trees_[t].buckets.reserve(trees_[t].buckets.size() + added[t]);
    trees_[t].parent.reserve(trees_[t].parent.size() + added[t]);
  }
  for (const SplitRecord& s : log) {
    if (s.tree >= trees_.size() || s.node >= trees_[s.tree].nodes.size() ||
        trees_[s.tree].nodes[s.node].left != kLeaf || s.dim >= dim_) {
      refuse("split log does not fit the forest (tree " + std::to_string(s.tree) + ", node " +
             std::to_string(s.node) + ")");
    }
    // With no free node, the children get the next two ids, as the log's format assumes.
    applySplit(s.tree, static_cast<std::int32_t>(s.node), s.dim, s.value);
  }
}

bool KdForest::pruneEmpty(std::uint32_t tree_index, std::int32_t node) {
  Tree& tree = trees_[tree_index];
  if (tree.nodes[node].left < 0) return !tree.buckets[node].empty();
  const std::int32_t left = tree.nodes[node].left;
  const std::int32_t right = tree.nodes[node].right;
  const bool left_live = pruneEmpty(tree_index, left);
  const bool right_live = pruneEmpty(tree_index, right);
  if (left_live && right_live) return true;
  if (!left_live && !right_live) {  // both are empty leaves by now
    release(tree, left);
    release(tree, right);
    tree.nodes[node].left = kLeaf;
    tree.nodes[node].right = kLeaf;
    return false;
  }
  spliceOut(tree_index, node, left_live ? right : left);
  return true;
}

void KdForest::collapseEmpty() {
  for (std::uint32_t t = 0; t < trees_.size(); ++t) pruneEmpty(t, 0);
  changed_all_ = true;
  for (Tree& tree : trees_) tree.changed.clear();
}

}  // namespace placedb::vocab
