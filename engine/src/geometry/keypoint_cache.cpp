#include "geometry/keypoint_cache.h"

namespace placedb {

const CachedKeypoints* KeypointCache::find(std::int64_t location) const {
  auto it = entries_.find(location);
  return it == entries_.end() ? nullptr : &it->second;
}

const CachedKeypoints& KeypointCache::insert(std::int64_t location, CachedKeypoints entry) {
  return entries_.insert_or_assign(location, std::move(entry)).first->second;
}

void KeypointCache::retainIf(const std::function<bool(std::int64_t)>& keep) {
  for (auto* map : {&entries_, &positions_}) {
    for (auto it = map->begin(); it != map->end();) {
      if (keep(it->first))
        ++it;
      else
        it = map->erase(it);
    }
  }
}

void KeypointCache::keepPositions(std::int64_t location, CachedKeypoints positions) {
  if (!entries_.count(location)) positions_.insert_or_assign(location, std::move(positions));
}

std::optional<CachedKeypoints> KeypointCache::takePositions(std::int64_t location) {
  auto node = positions_.extract(location);
  if (node.empty()) return std::nullopt;
  return std::move(node.mapped());
}

}  // namespace placedb
