#pragma once
// Paints one ground tile: multi-scale value noise under and over a scatter of shapes (ellipses,
// rings, rectangles, polygons, strokes, soft blobs, glyph marks, gradient patches). Shapes belong
// to the tile holding their centre but are painted into every tile they reach, in one global
// depth order, so tile borders leave no seams.
#include <cstdint>

#include <opencv2/core.hpp>

namespace placedb::synthetic {

// A tile_texels x tile_texels 8-bit grey tile whose top-left texel is
// (tile_x * tile_texels, tile_y * tile_texels). A pure function of its arguments.
cv::Mat paintTile(std::uint64_t seed, int tile_x, int tile_y, int tile_texels);

}  // namespace placedb::synthetic
