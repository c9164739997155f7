#pragma once
// The split log a schema-2 map would hold for given kd-trees: what the engine must still convert.
// Nodes are renumbered in the order a log assigns them (a split's children get the tree's next
// two ids), and `padding` extra splits send every point of some leaves to one side, leaving empty
// leaves behind as erased words did in such maps.
#include <cstdint>
#include <deque>
#include <map>
#include <utility>
#include <vector>

#include "vocabulary/kd_forest.h"

namespace placedb::testing {

inline std::vector<vocab::SplitRecord> legacySplitLog(const std::vector<vocab::ForestNode>& nodes,
                                                      int trees, int padding = 0) {
  std::vector<vocab::SplitRecord> log;
  for (int t = 0; t < trees; ++t) {
    std::map<std::uint32_t, const vocab::ForestNode*> internal;
    for (const auto& n : nodes)
      if (n.tree == t) internal[n.node] = &n;
    std::uint32_t next_id = 1;
    int padded = 0;
    std::deque<std::pair<std::uint32_t, std::uint32_t>> queue{{0, 0}};  // (node, id in the log)
    while (!queue.empty()) {
      auto [node, id] = queue.front();
      queue.pop_front();
      auto it = internal.find(node);
      if (it == internal.end()) {
        if (padded >= padding) continue;
        // A split no point follows to the right: replay leaves an empty right leaf.
        ++padded;
        log.push_back({static_cast<std::uint8_t>(t), id, 0, 1e30f});
        next_id += 2;
        continue;
      }
      log.push_back({static_cast<std::uint8_t>(t), id, it->second->dim, it->second->value});
      queue.emplace_back(it->second->left, next_id++);
      queue.emplace_back(it->second->right, next_id++);
    }
  }
  return log;
}

}  // namespace placedb::testing
