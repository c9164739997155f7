#include "features/integral_image.h"

namespace placedb {

IntegralImage::IntegralImage(const cv::Mat& grey8)
    : width_(grey8.cols),
      height_(grey8.rows),
      stride_(grey8.cols + 1),
      table_(static_cast<std::size_t>(grey8.cols + 1) * (grey8.rows + 1), 0u) {
  CV_Assert(grey8.type() == CV_8UC1);
  for (int y = 0; y < height_; ++y) {
    const std::uint8_t* pixels = grey8.ptr<std::uint8_t>(y);
    const std::uint32_t* above = &table_[static_cast<std::size_t>(y) * stride_];
    std::uint32_t* row = &table_[static_cast<std::size_t>(y + 1) * stride_];
    std::uint32_t row_sum = 0;
    for (int x = 0; x < width_; ++x) {
      row_sum += pixels[x];
      row[x + 1] = above[x + 1] + row_sum;
    }
  }
}

}  // namespace placedb
