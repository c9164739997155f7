#include "query_service.h"

#include <fmt/format.h>

#include "commands/map_summary.h"
#include "placedb/storage/map_store.h"
#include "ros_messages.h"

namespace placedb::ros_node {

bool QueryService::answer(placedb_msgs::Query::Request& request,
                          placedb_msgs::Query::Response& response) {
  std::lock_guard<std::mutex> lock(mutex_);
  const cli::DecodedImage image = request.image.data.empty() && !request.compressed.data.empty()
                                      ? decodeImage(request.compressed)
                                      : decodeImage(request.image);
  if (image.image.empty()) {
    response.error = fmt::format("the query image cannot be read: {}", image.problem);
    return true;
  }
  try {
    const std::int64_t committed = committed_.load();
    if (!map_ || committed != committed_at_open_) {
      map_.reset();
      const auto options = cli::lastSessionOptions(map_path_);
      if (!options) {
        response.error = fmt::format("map {} has no session yet: nothing to query",
                                     storage::mapDisplayName(map_path_));
        return true;
      }
      map_ = Map::open(map_path_, *options, Map::Mode::kLocalisation);
      committed_at_open_ = committed;
    }
    fillQueryResponse(map_->query(image.image, request.top ? request.top : 5), response);
  } catch (const std::exception& e) {  // placedb::Error, or OpenCV's on a strange image
    map_.reset();
    response.error = e.what();
  }
  return true;
}

}  // namespace placedb::ros_node
