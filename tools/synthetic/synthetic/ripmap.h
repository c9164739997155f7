#pragma once
// A texture filtered for oblique views. A plane seen at a grazing angle, such as a corridor's
// wall far ahead, squeezes many texels into one pixel along one axis only; sampling the full
// texture there aliases (noise that changes every frame, which no camera shows) and an ordinary
// mip level blurs the other axis too. A rip-map keeps the texture shrunk by every pair of powers
// of two (columns by 2^i, rows by 2^j); a lookup blends the four levels around the pixel's
// footprint along each axis, bilinearly in each.
#include <cstddef>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace placedb::synthetic {

class RipMap {
 public:
  // `base`: 8-bit grey, at least 1 x 1.
  explicit RipMap(const cv::Mat& base);
  RipMap(const RipMap&) = delete;
  RipMap& operator=(const RipMap&) = delete;
  RipMap(RipMap&&) = default;
  RipMap& operator=(RipMap&&) = default;

  int cols() const { return levels_[0].cols; }
  int rows() const { return levels_[0].rows; }

  // The levels and their weights for a pixel that covers `col_span` texels along the columns
  // and `row_span` along the rows; the same for every rip-map of the same size.
  struct Blend {
    int i0 = 0, i1 = 0, j0 = 0, j1 = 0;
    float wi = 0, wj = 0;
  };
  Blend blend(float col_span, float row_span) const;

  // The texture at base texel coordinates (col, row): texel centres at integers, edges clamped.
  float sample(const Blend& blend, float col, float row) const;
  // sample() of this map and of `other`, a map of the same size, at once (a picture and its
  // coverage): the same taps, read from both.
  void samplePair(const RipMap& other, const Blend& blend, float col, float row, float& mine,
                  float& others) const;

 private:
  struct Level {
    const std::uint8_t* data = nullptr;
    std::size_t step = 0;
    int cols = 0, rows = 0;
    float col_scale = 1, row_scale = 1;  // level texels per base texel
  };
  // Reads levels (i, j) of this map and of `other` (null: this map alone) bilinearly.
  void bilinear(const RipMap* other, int i, int j, float col, float row, float out[2]) const;
  const Level& level(int i, int j) const {
    return levels_[static_cast<std::size_t>(j) * col_levels_ + i];
  }

  int col_levels_ = 1, row_levels_ = 1;
  std::vector<cv::Mat> pixels_;  // level (i, j) at j * col_levels_ + i
  std::vector<Level> levels_;    // the same, ready to read
};

}  // namespace placedb::synthetic
