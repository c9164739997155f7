#include "synthetic/ground_texture.h"

#include <cmath>

#include "synthetic/tile_painter.h"

namespace placedb::synthetic {
namespace {

std::uint64_t keyOf(int tile_x, int tile_y) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(tile_x)) << 32) |
         static_cast<std::uint32_t>(tile_y);
}

int floorDiv(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

}  // namespace

GroundTexture::GroundTexture(std::uint64_t seed, std::size_t cache_tiles)
    : seed_(seed), capacity_(cache_tiles < 4 ? 4 : cache_tiles) {}

cv::Mat GroundTexture::renderTile(int tile_x, int tile_y) const {
  return paintTile(seed_, tile_x, tile_y, kTileTexels);
}

std::shared_ptr<const cv::Mat> GroundTexture::tile(int tile_x, int tile_y) const {
  const TileKey key = keyOf(tile_x, tile_y);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto found = cache_.find(key);
    if (found != cache_.end()) {
      lru_.splice(lru_.begin(), lru_, found->second.age);
      return found->second.tile;
    }
  }
  // Painted outside the lock: two threads may paint the same tile once each, harmlessly.
  auto painted = std::make_shared<const cv::Mat>(renderTile(tile_x, tile_y));
  std::lock_guard<std::mutex> lock(mutex_);
  auto found = cache_.find(key);
  if (found != cache_.end()) return found->second.tile;
  lru_.push_front(key);
  cache_.emplace(key, CacheEntry{painted, lru_.begin()});
  while (cache_.size() > capacity_) {
    cache_.erase(lru_.back());
    lru_.pop_back();
  }
  return painted;
}

cv::Mat GroundTexture::mosaic(const cv::Rect& texels) const {
  cv::Mat out(texels.size(), CV_8U);
  const int first_x = floorDiv(texels.x, kTileTexels);
  const int last_x = floorDiv(texels.x + texels.width - 1, kTileTexels);
  const int first_y = floorDiv(texels.y, kTileTexels);
  const int last_y = floorDiv(texels.y + texels.height - 1, kTileTexels);
  for (int ty = first_y; ty <= last_y; ++ty) {
    for (int tx = first_x; tx <= last_x; ++tx) {
      const cv::Rect tile_rect(tx * kTileTexels, ty * kTileTexels, kTileTexels, kTileTexels);
      const cv::Rect shared = tile_rect & texels;
      if (shared.empty()) continue;
      const auto pixels = tile(tx, ty);
      (*pixels)(shared - tile_rect.tl()).copyTo(out(shared - texels.tl()));
    }
  }
  return out;
}

std::size_t GroundTexture::cachedTiles() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return cache_.size();
}

}  // namespace placedb::synthetic
