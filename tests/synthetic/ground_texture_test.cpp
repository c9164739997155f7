#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "synthetic/ground_texture.h"

namespace placedb::synthetic {
namespace {

constexpr int kTile = GroundTexture::kTileTexels;

TEST(GroundTexture, TilesAreRepeatableAndPlaceSpecific) {
  GroundTexture texture(42, 8);
  const cv::Mat first = texture.renderTile(3, -2);
  const cv::Mat again = GroundTexture(42, 8).renderTile(3, -2);
  EXPECT_EQ(cv::norm(first, again, cv::NORM_INF), 0);
  const cv::Mat elsewhere = texture.renderTile(4, -2);
  const cv::Mat other_seed = GroundTexture(43, 8).renderTile(3, -2);
  EXPECT_GT(cv::norm(first, elsewhere, cv::NORM_L1) / first.total(), 15);
  EXPECT_GT(cv::norm(first, other_seed, cv::NORM_L1) / first.total(), 15);
}

TEST(GroundTexture, MosaicMatchesTilesAcrossBordersAndNegativeCoordinates) {
  GroundTexture texture(5, 4);  // smaller than the mosaic: forces evictions
  const cv::Rect area(-kTile - 37, -20, 2 * kTile + 80, kTile + 60);
  const cv::Mat mosaic = texture.mosaic(area);
  for (int ty = -1; ty <= 1; ++ty) {
    for (int tx = -2; tx <= 1; ++tx) {
      const cv::Rect tile_rect(tx * kTile, ty * kTile, kTile, kTile);
      const cv::Rect shared = tile_rect & area;
      if (shared.empty()) continue;
      const cv::Mat tile = texture.renderTile(tx, ty);
      EXPECT_EQ(cv::norm(tile(shared - tile_rect.tl()), mosaic(shared - area.tl()), cv::NORM_INF),
                0)
          << tx << "," << ty;
    }
  }
  EXPECT_LE(texture.cachedTiles(), 4u);
}

// Shapes that straddle a border are painted into both tiles, so the texture does not jump there:
// neighbouring columns across a border differ no more than neighbouring columns inside a tile.
TEST(GroundTexture, TileBordersLeaveNoSeams) {
  GroundTexture texture(9, 16);
  const cv::Mat strip = texture.mosaic(cv::Rect(-kTile, 0, 2 * kTile, 2 * kTile));
  auto columnStep = [&](int col) {
    return cv::norm(strip.col(col), strip.col(col + 1), cv::NORM_L1) / strip.rows;
  };
  double inside = 0;
  int samples = 0;
  for (int col = 20; col < 2 * kTile - 21; col += 7) {
    if (col == kTile - 1) continue;
    inside += columnStep(col);
    ++samples;
  }
  inside /= samples;
  EXPECT_LT(columnStep(kTile - 1), 2.0 * inside + 1.0);
  // The texture is not flat: there is structure for detectors.
  cv::Scalar mean, stddev;
  cv::meanStdDev(strip, mean, stddev);
  EXPECT_GT(stddev[0], 25);
}

}  // namespace
}  // namespace placedb::synthetic
