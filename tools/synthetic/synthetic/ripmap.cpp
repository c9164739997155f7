#include "synthetic/ripmap.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <opencv2/imgproc.hpp>

namespace placedb::synthetic {
namespace {

int levelsOf(int size) {
  int levels = 1;
  while ((size >> levels) >= 1) ++levels;
  return levels;
}

int shrunk(int size, int level) { return std::max(1, (size + (1 << level) - 1) >> level); }

// log2(x) for x >= 1, exact at powers of two and linear between them (as graphics hardware
// picks mip levels): monotonic, cheap, and the same on every platform.
float levelOf(float x) {
  std::uint32_t bits = 0;
  std::memcpy(&bits, &x, sizeof bits);
  const int exponent = static_cast<int>((bits >> 23) & 0xff) - 127;
  bits = (bits & 0x007fffffu) | 0x3f800000u;  // the mantissa, in [1, 2)
  float mantissa = 0;
  std::memcpy(&mantissa, &bits, sizeof mantissa);
  return static_cast<float>(exponent) + mantissa - 1.0f;
}

}  // namespace

RipMap::RipMap(const cv::Mat& base) {
  CV_Assert(base.type() == CV_8U && !base.empty());
  col_levels_ = levelsOf(base.cols);
  row_levels_ = levelsOf(base.rows);
  pixels_.resize(static_cast<std::size_t>(col_levels_) * row_levels_);
  levels_.resize(pixels_.size());
  for (int j = 0; j < row_levels_; ++j) {
    for (int i = 0; i < col_levels_; ++i) {
      const std::size_t at = static_cast<std::size_t>(j) * col_levels_ + i;
      if (i == 0 && j == 0) {
        pixels_[at] = base.clone();
      } else {
        // Halve one axis of a neighbour: box filters, so every level averages its texels.
        const cv::Mat& from = i > 0 ? pixels_[at - 1] : pixels_[at - col_levels_];
        cv::resize(from, pixels_[at], cv::Size(shrunk(base.cols, i), shrunk(base.rows, j)), 0, 0,
                   cv::INTER_AREA);
      }
      const cv::Mat& m = pixels_[at];
      levels_[at] = {m.ptr<std::uint8_t>(0),
                     m.step[0],
                     m.cols,
                     m.rows,
                     static_cast<float>(m.cols) / base.cols,
                     static_cast<float>(m.rows) / base.rows};
    }
  }
}

RipMap::Blend RipMap::blend(float col_span, float row_span) const {
  // A pixel that spans 2^k texels reads level k, where it spans about one.
  Blend b;
  const float li = std::min(levelOf(std::max(col_span, 1.0f)), col_levels_ - 1.0f);
  const float lj = std::min(levelOf(std::max(row_span, 1.0f)), row_levels_ - 1.0f);
  b.i0 = static_cast<int>(li);
  b.j0 = static_cast<int>(lj);
  b.i1 = std::min(b.i0 + 1, col_levels_ - 1);
  b.j1 = std::min(b.j0 + 1, row_levels_ - 1);
  b.wi = li - b.i0;
  b.wj = lj - b.j0;
  // Weights within 1/32 of a level read one level instead of two: no visible step, and most
  // pixels are magnified (level 0 along both axes) or close to a level.
  constexpr float kSnap = 1.0f / 32;
  if (b.wi > 1 - kSnap) b.i0 = b.i1;
  if (b.wi < kSnap || b.wi > 1 - kSnap) b.wi = 0;
  if (b.wj > 1 - kSnap) b.j0 = b.j1;
  if (b.wj < kSnap || b.wj > 1 - kSnap) b.wj = 0;
  return b;
}

void RipMap::bilinear(const RipMap* other, int i, int j, float col, float row, float out[2]) const {
  const Level& level = this->level(i, j);
  // Base texel centres to this level's texel centres (the level may round its size up).
  const float x =
      std::clamp((col + 0.5f) * level.col_scale - 0.5f, 0.0f, static_cast<float>(level.cols - 1));
  const float y =
      std::clamp((row + 0.5f) * level.row_scale - 0.5f, 0.0f, static_cast<float>(level.rows - 1));
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const int x1 = std::min(x0 + 1, level.cols - 1), y1 = std::min(y0 + 1, level.rows - 1);
  const float fx = x - x0, fy = y - y0;
  const auto read = [&](const Level& from) {
    const std::uint8_t* top = from.data + from.step * y0;
    const std::uint8_t* bottom = from.data + from.step * y1;
    const float upper = top[x0] + fx * (top[x1] - top[x0]);
    const float lower = bottom[x0] + fx * (bottom[x1] - bottom[x0]);
    return upper + fy * (lower - upper);
  };
  out[0] = read(level);
  if (other) out[1] = read(other->level(i, j));
}

void RipMap::samplePair(const RipMap& other, const Blend& b, float col, float row, float& mine,
                        float& others) const {
  const RipMap* second = &other;
  if (this == &other) second = nullptr;
  // Blend the four levels around the footprint: along the columns, then along the rows.
  float near_rows[2] = {0, 0}, far_rows[2] = {0, 0}, tap[2] = {0, 0};
  bilinear(second, b.i0, b.j0, col, row, near_rows);
  if (b.wi > 0) {
    bilinear(second, b.i1, b.j0, col, row, tap);
    for (int c = 0; c < 2; ++c) near_rows[c] += b.wi * (tap[c] - near_rows[c]);
  }
  if (b.wj > 0) {
    bilinear(second, b.i0, b.j1, col, row, far_rows);
    if (b.wi > 0) {
      bilinear(second, b.i1, b.j1, col, row, tap);
      for (int c = 0; c < 2; ++c) far_rows[c] += b.wi * (tap[c] - far_rows[c]);
    }
    for (int c = 0; c < 2; ++c) near_rows[c] += b.wj * (far_rows[c] - near_rows[c]);
  }
  mine = near_rows[0];
  others = second ? near_rows[1] : near_rows[0];
}

float RipMap::sample(const Blend& b, float col, float row) const {
  float value = 0, same = 0;
  samplePair(*this, b, col, row, value, same);
  return value;
}

}  // namespace placedb::synthetic
