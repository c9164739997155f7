#include "filter/link_graph.h"

#include <algorithm>
#include <deque>
#include <string>
#include <unordered_map>

#include "placedb/error.h"

namespace placedb {

void LinkGraph::addNode(LocationId id) { adjacency_[id]; }

void LinkGraph::removeNode(LocationId id) {
  auto it = adjacency_.find(id);
  if (it == adjacency_.end()) return;
  for (LocationId other : it->second) {
    adjacency_[other].erase(id);
    loop_closures_.erase(std::minmax(id, other));
  }
  adjacency_.erase(it);
}

void LinkGraph::addLink(LocationId a, LocationId b, LinkKind kind) {
  if (a == b) {
    throw Error(ErrorCode::kInvalidArgument,
                "link graph: self-link on location " + std::to_string(a) + " refused");
  }
  adjacency_[a].insert(b);
  adjacency_[b].insert(a);
  if (kind == LinkKind::kLoopClosure)
    loop_closures_.insert(std::minmax(a, b));
  else
    loop_closures_.erase(std::minmax(a, b));
}

void LinkGraph::removeLink(LocationId a, LocationId b) {
  auto ia = adjacency_.find(a);
  if (ia != adjacency_.end()) ia->second.erase(b);
  auto ib = adjacency_.find(b);
  if (ib != adjacency_.end()) ib->second.erase(a);
  loop_closures_.erase(std::minmax(a, b));
}

bool LinkGraph::isLoopClosure(LocationId a, LocationId b) const {
  return loop_closures_.count(std::minmax(a, b)) != 0;
}

bool LinkGraph::hasLink(LocationId a, LocationId b) const {
  auto it = adjacency_.find(a);
  return it != adjacency_.end() && it->second.count(b) != 0;
}

std::vector<LocationId> LinkGraph::neighbours(LocationId id) const {
  auto it = adjacency_.find(id);
  if (it == adjacency_.end()) return {};
  return {it->second.begin(), it->second.end()};
}

const std::set<LocationId>& LinkGraph::neighbourSet(LocationId id) const {
  static const std::set<LocationId> kNone;
  auto it = adjacency_.find(id);
  return it == adjacency_.end() ? kNone : it->second;
}

std::vector<std::pair<LocationId, int>> LinkGraph::withinLinks(LocationId start, int max_depth,
                                                               const NodeFilter& allowed,
                                                               LinkWalk walk) const {
  std::vector<std::pair<LocationId, int>> found;
  if (max_depth < 0 || adjacency_.count(start) == 0) return found;
  if (allowed && !allowed(start)) return found;
  std::unordered_map<LocationId, int> depth_of{{start, 0}};
  std::deque<LocationId> frontier{start};
  while (!frontier.empty()) {
    const LocationId node = frontier.front();
    frontier.pop_front();
    const int depth = depth_of[node];
    found.emplace_back(node, depth);
    if (depth == max_depth) continue;
    for (LocationId next : adjacency_.at(node)) {
      if (depth_of.count(next) != 0) continue;
      if (allowed && !allowed(next)) continue;
      if (walk == LinkWalk::kNeighbourLinksOnly && isLoopClosure(node, next)) continue;
      depth_of.emplace(next, depth + 1);
      frontier.push_back(next);
    }
  }
  std::sort(found.begin(), found.end());
  return found;
}

}  // namespace placedb
