#pragma once
// The synthetic world's ground: an endless procedural texture made tile by tile from a hash of
// (seed, tile x, tile y), so any place can be regenerated alone and looks the same every time.
#include <cstddef>
#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <unordered_map>

#include <opencv2/core.hpp>

namespace placedb::synthetic {

// Texel (col, row) is the ground point (col / kTexelsPerMetre, -row / kTexelsPerMetre): rows grow
// southwards so the texture reads the right way round when seen from above.
class GroundTexture {
 public:
  static constexpr int kTileTexels = 256;
  static constexpr double kTexelsPerMetre = 32.0;

  GroundTexture(std::uint64_t seed, std::size_t cache_tiles);

  // 8-bit grey texels of the rectangle `texels` (in global texel coordinates). Thread-safe.
  cv::Mat mosaic(const cv::Rect& texels) const;

  // One tile, from the cache when it is there. Thread-safe.
  std::shared_ptr<const cv::Mat> tile(int tile_x, int tile_y) const;

  // One tile made from scratch (what the cache holds).
  cv::Mat renderTile(int tile_x, int tile_y) const;

  std::size_t cachedTiles() const;

 private:
  using TileKey = std::uint64_t;
  struct CacheEntry {
    std::shared_ptr<const cv::Mat> tile;
    std::list<TileKey>::iterator age;
  };

  std::uint64_t seed_;
  std::size_t capacity_;
  mutable std::mutex mutex_;
  mutable std::list<TileKey> lru_;  // most recently used first
  mutable std::unordered_map<TileKey, CacheEntry> cache_;
};

}  // namespace placedb::synthetic
