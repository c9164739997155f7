#include "features/integral_image.h"

#include <algorithm>
#include <utility>

namespace placedb {
namespace {

// Tables of images that went, kept for the next image their thread integrates: a fresh table
// comes zeroed (and, for a 240x192 image's 186 KB, from mmap), and every frame paid for it
// again, twice where a small image is searched again at twice its size.
constexpr std::size_t kKeptTables = 4;

std::vector<std::vector<std::uint32_t>>& keptTables() {
  thread_local std::vector<std::vector<std::uint32_t>> kept = [] {
    std::vector<std::vector<std::uint32_t>> empty;
    empty.reserve(kKeptTables);  // keeping a table in a destructor allocates nothing
    return empty;
  }();
  return kept;
}

std::vector<std::uint32_t> takeTable(std::size_t entries) {
  std::vector<std::uint32_t> table;
  auto& kept = keptTables();
  if (!kept.empty()) {
    table = std::move(kept.back());
    kept.pop_back();
  }
  if (table.size() < entries) table.resize(entries);
  return table;
}

void keepTable(std::vector<std::uint32_t>& table) {
  auto& kept = keptTables();
  if (table.empty() || kept.size() >= kKeptTables) return;
  kept.push_back(std::move(table));
  table.clear();
}

}  // namespace

IntegralImage::IntegralImage(const cv::Mat& grey8)
    : width_(grey8.cols),
      height_(grey8.rows),
      stride_(grey8.cols + 1),
      table_(takeTable(static_cast<std::size_t>(grey8.cols + 1) * (grey8.rows + 1))) {
  CV_Assert(grey8.type() == CV_8UC1);
  // Row 0 and column 0 are the empty sums; every other entry is written below.
  std::fill(table_.begin(), table_.begin() + stride_, 0u);
  for (int y = 0; y < height_; ++y) {
    const std::uint8_t* pixels = grey8.ptr<std::uint8_t>(y);
    const std::uint32_t* above = &table_[static_cast<std::size_t>(y) * stride_];
    std::uint32_t* row = &table_[static_cast<std::size_t>(y + 1) * stride_];
    row[0] = 0;
    std::uint32_t row_sum = 0;
    for (int x = 0; x < width_; ++x) {
      row_sum += pixels[x];
      row[x + 1] = above[x + 1] + row_sum;
    }
  }
}

IntegralImage::~IntegralImage() { keepTable(table_); }

IntegralImage& IntegralImage::operator=(IntegralImage&& other) noexcept {
  if (this != &other) {
    keepTable(table_);
    width_ = other.width_;
    height_ = other.height_;
    stride_ = other.stride_;
    table_ = std::move(other.table_);
  }
  return *this;
}

}  // namespace placedb
