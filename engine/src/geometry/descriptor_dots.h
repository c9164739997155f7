#pragma once
// The ratio matcher's inner loop: integer dot products of query code rows with every code row of
// a candidate. Each query row meets all ~300 candidate rows, so the candidate rows are laid out
// for that: blocks of kDotBlockRows rows, and within a block the dimensions in pairs, the rows
// side by side. One instruction then multiplies a pair of the query's dimensions with a pair of
// each of 16 rows (AVX-512 VNNI; two with AVX2), and no row needs a sum across its lanes. The
// loop is bound by reading the candidate's codes, so a pass over them serves several query rows.
// The sums are exact integers, so every instruction set gives the same products.
#include <cstdint>
#include <vector>

namespace placedb {

constexpr int kDotBlockRows = 16;

// Candidate rows laid out for codeDots(): `rows` x `dim` codes (row-major, dim even) into
// ceil(rows / 16) blocks of dim / 2 pairs of 16 rows x 2 codes; missing rows are zeros.
std::vector<std::int16_t> blockCodes(const std::int16_t* codes, int rows, int dim);

// Row `row` of a blocked layout, its dim codes into `out` (as T).
template <typename T>
void blockedRow(const std::int16_t* blocked, int dim, int row, T* out) {
  const std::size_t pair_codes = 2 * kDotBlockRows;
  const std::int16_t* from =
      blocked + static_cast<std::size_t>(row / kDotBlockRows) * (dim / 2) * pair_codes +
      static_cast<std::size_t>(row % kDotBlockRows) * 2;
  for (int p = 0; p < dim / 2; ++p, from += pair_codes) {
    out[2 * p] = static_cast<T>(from[0]);
    out[2 * p + 1] = static_cast<T>(from[1]);
  }
}

// Query rows a call takes at once, each load of the candidate's codes serving them all.
constexpr int kDotQueryRows = 4;

// out[i * stride + r] = sum over k of queries[i * dim + k] * (row r of `blocked`)[k], for the
// first `count` (1..kDotQueryRows) query rows and r in [0, rows rounded up to 16): each output
// row has room for that many. dim * max|query| * max|code| must stay below 2^31, so that no sum
// can overflow.
void codeDots(const std::int16_t* queries, int count, const std::int16_t* blocked, int rows,
              int dim, std::int32_t* out, std::size_t stride);

// The instruction sets codeDots() picks from, the best this processor has first; each gives the
// same sums. Named so that a test can hold every one available to the same products.
enum class DotKernel { kVnni, kAvx2, kPlain };
bool dotKernelAvailable(DotKernel kernel);
void codeDots(DotKernel kernel, const std::int16_t* queries, int count, const std::int16_t* blocked,
              int rows, int dim, std::int32_t* out, std::size_t stride);

}  // namespace placedb
