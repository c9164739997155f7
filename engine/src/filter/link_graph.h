#pragma once
// Undirected graph of links between locations (neighbour links between consecutive locations and
// loop-closure links), used to spread the filter's prediction along the map.
#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <utility>
#include <vector>

#include "filter/signature.h"

namespace placedb {

// Neighbour links join a traversal's consecutive locations; loop-closure links join two visits.
enum class LinkKind { kNeighbour, kLoopClosure };
// Which links a walk follows.
enum class LinkWalk { kAnyLink, kNeighbourLinksOnly };

class LinkGraph {
 public:
  void addNode(LocationId id);  // no-op when present
  // Drops the node and every link touching it; no-op when absent.
  void removeNode(LocationId id);
  // Adds both nodes if needed. Self-links are refused (kInvalidArgument): a location is always
  // at distance 0 of itself anyway. A link added again takes the later kind.
  void addLink(LocationId a, LocationId b, LinkKind kind = LinkKind::kNeighbour);
  void removeLink(LocationId a, LocationId b);

  bool hasNode(LocationId id) const { return adjacency_.count(id) != 0; }
  bool hasLink(LocationId a, LocationId b) const;
  bool isLoopClosure(LocationId a, LocationId b) const;  // a link of kind kLoopClosure
  std::size_t nodeCount() const { return adjacency_.size(); }
  // Sorted; empty when the node is absent.
  std::vector<LocationId> neighbours(LocationId id) const;
  // The same without a copy (an empty set when the node is absent).
  const std::set<LocationId>& neighbourSet(LocationId id) const;

  // Nodes within max_depth links of start (start itself at depth 0), walking only through nodes
  // the filter accepts (start included: nothing is returned when start is refused or absent).
  // Sorted by node id. Neighbours are expanded in id order, so the result never depends on the
  // order links were added. kNeighbourLinksOnly stays on the traversals start lies on.
  using NodeFilter = std::function<bool(LocationId)>;
  std::vector<std::pair<LocationId, int>> withinLinks(LocationId start, int max_depth,
                                                      const NodeFilter& allowed = nullptr,
                                                      LinkWalk walk = LinkWalk::kAnyLink) const;

 private:
  std::map<LocationId, std::set<LocationId>> adjacency_;
  std::set<std::pair<LocationId, LocationId>> loop_closures_;  // (smaller, larger) id
};

}  // namespace placedb
