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
  for (auto it = entries_.begin(); it != entries_.end();) {
    if (keep(it->first))
      ++it;
    else
      it = entries_.erase(it);
  }
}

}  // namespace placedb
