#pragma once
// The node's query service: one image in, `placedb query`'s verdict and matches out. It reads
// the map through a read-only Map of its own (a map being mapped cannot answer queries: the
// Python module's rule), opened at the first query and opened again once the mapping has
// committed frames since, so that every answer sees the map as of its last committed frame.
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include <placedb_msgs/Query.h>

#include "placedb/map.h"

namespace placedb::ros_node {

class QueryService {
 public:
  explicit QueryService(std::string map_path) : map_path_(std::move(map_path)) {}
  // The mapping committed a frame (any thread).
  void frameCommitted() { ++committed_; }
  // Fills `response` (its `error` when the image or the map cannot be used); always true, so
  // that the caller gets the reason.
  bool answer(placedb_msgs::Query::Request& request, placedb_msgs::Query::Response& response);

 private:
  std::string map_path_;
  std::atomic<std::int64_t> committed_{0};
  std::mutex mutex_;  // queries take turns: the Map is not shared between threads
  std::unique_ptr<Map> map_;
  std::int64_t committed_at_open_ = -1;
};

}  // namespace placedb::ros_node
