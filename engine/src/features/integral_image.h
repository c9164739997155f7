#pragma once
// Summed-area table of an 8-bit image, exact for any image size.
//
// Entries are uint32 and may wrap around for very large images; that is harmless because every
// box sum is a difference of entries, and modular arithmetic gives the exact sum as long as the
// box itself holds less than 2^31 (8.4 million pixels of 255): far beyond any SURF filter.
// This keeps the table half the size of int64/double and the arithmetic exact and deterministic.
#include <algorithm>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace placedb {

class IntegralImage {
 public:
  explicit IntegralImage(const cv::Mat& grey8);
  // A table that goes is kept for the next one its thread builds (integral_image.cpp).
  ~IntegralImage();
  IntegralImage(IntegralImage&& other) noexcept = default;
  IntegralImage& operator=(IntegralImage&& other) noexcept;
  IntegralImage(const IntegralImage&) = delete;
  IntegralImage& operator=(const IntegralImage&) = delete;

  int width() const { return width_; }
  int height() const { return height_; }
  // Entries per row: width() + 1.
  int stride() const { return stride_; }
  // Entry (x, y) holds the sum of pixels [0, x) x [0, y).
  const std::uint32_t* data() const { return table_.data(); }

  // Sum of pixels [x0, x1) x [y0, y1); the box must lie inside the image.
  int boxSum(int x0, int y0, int x1, int y1) const {
    const std::uint32_t* t = table_.data();
    const std::uint32_t sum =
        t[y1 * stride_ + x1] - t[y0 * stride_ + x1] - t[y1 * stride_ + x0] + t[y0 * stride_ + x0];
    return static_cast<std::int32_t>(sum);
  }

  // The same with every coordinate clamped into the image (boxes outside count as empty).
  int boxSumClamped(int x0, int y0, int x1, int y1) const {
    return boxSum(clampX(x0), clampY(y0), clampX(x1), clampY(y1));
  }
  int clampX(int x) const { return std::min(std::max(x, 0), width_); }
  int clampY(int y) const { return std::min(std::max(y, 0), height_); }

 private:
  int width_ = 0, height_ = 0, stride_ = 1;
  std::vector<std::uint32_t> table_;  // at least (width + 1) x (height + 1) entries
};

}  // namespace placedb
