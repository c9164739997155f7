// The matcher's dot products on the candidate layout: every product exact, whatever the row
// count (a last block part empty) and the size of the codes.
#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "geometry/descriptor_dots.h"

namespace placedb {
namespace {

TEST(CodeDots, EqualsTheRowByRowSumsForAnyRowCount) {
  std::mt19937 rng(21);
  constexpr int kDim = 64;
  std::uniform_int_distribution<int> query_code(-8191, 8191), row_code(-128, 127);
  for (int rows : {1, 2, 15, 16, 17, 31, 130, 301}) {
    std::vector<std::int16_t> queries(kDotQueryRows * kDim),
        codes(static_cast<std::size_t>(rows) * kDim);
    for (auto& q : queries) q = static_cast<std::int16_t>(query_code(rng));
    for (auto& c : codes) c = static_cast<std::int16_t>(row_code(rng));
    // The extremes, where a wrong width or sign would show.
    queries[0] = 8191;
    queries[1] = -8191;
    codes[0] = -128;
    codes[1] = 127;
    const std::vector<std::int16_t> blocked = blockCodes(codes.data(), rows, kDim);
    for (int r = 0; r < rows; ++r) {
      std::int16_t row[kDim];
      blockedRow(blocked.data(), kDim, r, row);
      for (int k = 0; k < kDim; ++k)
        ASSERT_EQ(row[k], codes[static_cast<std::size_t>(r) * kDim + k]) << r << ", " << k;
    }
    const std::size_t stride = (rows + kDotBlockRows - 1) / kDotBlockRows * kDotBlockRows;
    const auto expectRight = [&](const std::vector<std::int32_t>& out, int count,
                                 const std::string& what) {
      for (int i = 0; i < count; ++i) {
        for (int r = 0; r < rows; ++r) {
          std::int64_t want = 0;
          for (int k = 0; k < kDim; ++k)
            want += std::int64_t{queries[static_cast<std::size_t>(i) * kDim + k]} *
                    codes[static_cast<std::size_t>(r) * kDim + k];
          EXPECT_EQ(out[i * stride + r], want) << what << ", " << count << " queries, " << rows
                                               << " rows: query " << i << ", row " << r;
        }
      }
    };
    for (int count = 1; count <= kDotQueryRows; ++count) {
      for (DotKernel kernel : {DotKernel::kVnni, DotKernel::kAvx2, DotKernel::kPlain}) {
        if (!dotKernelAvailable(kernel)) continue;
        std::vector<std::int32_t> out(stride * kDotQueryRows);
        codeDots(kernel, queries.data(), count, blocked.data(), rows, kDim, out.data(), stride);
        expectRight(out, count, "kernel " + std::to_string(static_cast<int>(kernel)));
      }
      std::vector<std::int32_t> best(stride * kDotQueryRows);
      codeDots(queries.data(), count, blocked.data(), rows, kDim, best.data(), stride);
      expectRight(best, count, "best kernel");
    }
  }
}

}  // namespace
}  // namespace placedb
