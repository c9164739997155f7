#include "memory/place_lists.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <numeric>

#include "features/parallel_for.h"
#include "memory/place_code.h"

namespace placedb {
namespace {

// The mean `sum` / members of unit codes as bytes, scaled so that its largest value is +-127 (the
// bytes keep as much of it as they can, and stay within encodedCodeDots' range); returns that
// scale, bytes over mean.
double roundedMean(const double* sum, std::size_t members, std::size_t dim, std::int8_t* out) {
  double largest = 0;
  for (std::size_t d = 0; d < dim; ++d) largest = std::max(largest, std::abs(sum[d]));
  for (std::size_t d = 0; d < dim; ++d)
    out[d] = largest == 0
                 ? 0
                 : static_cast<std::int8_t>(std::lround(127.0 * double(sum[d]) / double(largest)));
  return largest == 0 ? 1.0 : 127.0 * double(members) / double(largest);
}

}  // namespace

void PlaceLists::setCentres(std::vector<std::int8_t> centres, std::vector<double> scales) {
  centres_ = std::move(centres);
  scales_ = std::move(scales);
  const std::size_t lists = centres_.size() / dim_;
  half_norm2_.resize(lists);
  for (std::size_t l = 0; l < lists; ++l) {
    const std::int8_t* c = centres_.data() + l * dim_;
    half_norm2_[l] = double(codeDot(c, c, dim_)) / (2 * scales_[l] * scales_[l]);
  }
  rows_.assign(lists, {});
  codes_.assign(lists, {});
}

void PlaceLists::addRow(std::uint32_t row, const std::int8_t* code) {
  const std::size_t list = nearest(code);
  rows_[list].push_back(row);
  codes_[list].insert(codes_[list].end(), code, code + dim_);
}

void PlaceLists::scores(const std::int8_t* code, double* out) const {
  const std::size_t lists = rows_.size();
  thread_local std::vector<std::int32_t> products;
  products.resize(lists);
  // Centres are within range by construction; a code may not be (no encoder makes one).
  (withinEncodedRange(code, dim_) ? encodedCodeDots : codeDots)(code, centres_.data(), lists, dim_,
                                                                products.data());
  // Of the unit code u = x / |x| and each list's mean c: -|u - c|^2 / 2 less the 1/2 every
  // centre shares, so the nearest scores highest. Unit codes because the search ranks cosines:
  // the encoder scales each code by its largest value, so lengths differ by more than the
  // distances that separate places (by the length, lists held twice the codes for the same
  // recall: bench/scale/README.md).
  const double n = std::sqrt(double(codeDot(code, code, dim_)));
  for (std::size_t l = 0; l < lists; ++l)
    out[l] = n == 0 ? 0.0 : double(products[l]) / (scales_[l] * n) - half_norm2_[l];
}

std::size_t PlaceLists::nearest(const std::int8_t* code) const {
  thread_local std::vector<double> s;
  s.resize(rows_.size());
  scores(code, s.data());
  return std::size_t(std::max_element(s.begin(), s.end()) - s.begin());  // first of equals
}

std::vector<std::size_t> PlaceLists::nearest(const std::int8_t* code, std::size_t count) const {
  thread_local std::vector<double> s;
  s.resize(rows_.size());
  scores(code, s.data());
  std::vector<std::size_t> order(rows_.size());
  std::iota(order.begin(), order.end(), 0);
  count = std::min(count, order.size());
  std::partial_sort(
      order.begin(), order.begin() + count, order.end(),
      [&](std::size_t a, std::size_t b) { return s[a] != s[b] ? s[a] > s[b] : a < b; });
  order.resize(count);
  return order;
}

PlaceLists PlaceLists::train(const std::vector<const std::int8_t*>& codes, std::size_t dim,
                             std::size_t lists, int threads) {
  PlaceLists out;
  out.dim_ = dim;
  const std::size_t n = codes.size();
  lists = std::max<std::size_t>(1, std::min(lists, n));
  std::vector<std::int8_t> centres(lists * dim);
  for (std::size_t l = 0; l < lists; ++l)
    std::copy(codes[l * n / lists], codes[l * n / lists] + dim, centres.data() + l * dim);
  std::vector<double> first_scales(lists);
  for (std::size_t l = 0; l < lists; ++l) {
    const std::int8_t* c = centres.data() + l * dim;
    const double n = std::sqrt(double(codeDot(c, c, dim)));
    first_scales[l] = n > 0 ? n : 1.0;  // the centre is the unit code
  }
  out.setCentres(std::move(centres), std::move(first_scales));
  std::vector<std::size_t> owner(n);
  std::vector<double> sums(lists * dim);
  for (int round = 0; round < kIterations; ++round) {
    // Each code's nearest centre on its own (a task a block of codes): the same whatever the
    // thread that computes it.
    constexpr std::size_t kBlock = 256;
    parallelFor(int((n + kBlock - 1) / kBlock), threads, [&](int b) {
      const std::size_t end = std::min(n, (std::size_t(b) + 1) * kBlock);
      for (std::size_t i = std::size_t(b) * kBlock; i < end; ++i) owner[i] = out.nearest(codes[i]);
    });
    std::fill(sums.begin(), sums.end(), 0.0);
    std::vector<std::size_t> members(lists, 0);
    for (std::size_t i = 0; i < n; ++i) {
      double* sum = sums.data() + owner[i] * dim;
      const double length = std::sqrt(double(codeDot(codes[i], codes[i], dim)));
      if (length > 0)
        for (std::size_t d = 0; d < dim; ++d) sum[d] += codes[i][d] / length;
      ++members[owner[i]];
    }
    std::vector<std::int8_t> next = out.centres_;
    std::vector<double> scales = out.scales_;
    for (std::size_t l = 0; l < lists; ++l)  // an empty list keeps its centre
      if (members[l] > 0)
        scales[l] = roundedMean(sums.data() + l * dim, members[l], dim, next.data() + l * dim);
    if (next == out.centres_ && scales == out.scales_) break;  // another round changes nothing
    out.setCentres(std::move(next), std::move(scales));
  }
  return out;
}

}  // namespace placedb
