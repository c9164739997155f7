#include "geometry/descriptor_dots.h"

#include <cstring>
#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#endif

#include "features/cpu_support.h"

namespace placedb {
namespace {

// Codes of one pair of dimensions of one block: 16 rows x 2.
constexpr std::size_t kPairCodes = 2 * kDotBlockRows;

std::int32_t pairOf(const std::int16_t* query, int pair) {
  std::int32_t both;
  std::memcpy(&both, query + 2 * pair, sizeof both);
  return both;
}

// Every kernel: `count` query rows (at most kDotQueryRows, row-major) against `blocks` blocks,
// products of query i into out + i * stride.
void codeDotsPlain(const std::int16_t* queries, int count, const std::int16_t* blocked, int blocks,
                   int dim, std::int32_t* out, std::size_t stride) {
  const int pairs = dim / 2;
  for (int i = 0; i < count; ++i) {
    const std::int16_t* query = queries + static_cast<std::size_t>(i) * dim;
    for (int b = 0; b < blocks; ++b) {
      std::int32_t sums[kDotBlockRows] = {};
      for (int p = 0; p < pairs; ++p) {
        const std::int16_t* codes =
            blocked + (static_cast<std::size_t>(b) * pairs + p) * kPairCodes;
        for (int r = 0; r < kDotBlockRows; ++r)
          sums[r] += query[2 * p] * codes[2 * r] + query[2 * p + 1] * codes[2 * r + 1];
      }
      std::memcpy(out + i * stride + b * kDotBlockRows, sums, sizeof sums);
    }
  }
}

#if defined(__GNUC__) && defined(__x86_64__)
#define PLACEDB_CODE_DOTS_X86 1

// Each load of a candidate block serves Q query rows, and each broadcast pair of a query serves
// several blocks, the sums all in registers: a candidate's ~40 KB of codes stream through once
// per Q query rows. (Lambdas would not inherit the target attribute, hence the plain loops.)
template <int Q>
__attribute__((target("avx2"))) void codeDotsAvx2(const std::int16_t* queries,
                                                  const std::int16_t* blocked, int blocks, int dim,
                                                  std::int32_t* out, std::size_t stride) {
  const int pairs = dim / 2;
  for (int b = 0; b < blocks; ++b) {
    __m256i lo[Q], hi[Q];  // rows 0-7 and 8-15 of the block, per query row
    for (int i = 0; i < Q; ++i) lo[i] = hi[i] = _mm256_setzero_si256();
    const std::int16_t* block = blocked + static_cast<std::size_t>(b) * pairs * kPairCodes;
    for (int p = 0; p < pairs; ++p) {
      const __m256i c_lo = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(block));
      const __m256i c_hi = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(block + 16));
      block += kPairCodes;
      for (int i = 0; i < Q; ++i) {
        const __m256i q = _mm256_set1_epi32(pairOf(queries + static_cast<std::size_t>(i) * dim, p));
        lo[i] = _mm256_add_epi32(lo[i], _mm256_madd_epi16(q, c_lo));
        hi[i] = _mm256_add_epi32(hi[i], _mm256_madd_epi16(q, c_hi));
      }
    }
    for (int i = 0; i < Q; ++i) {
      std::int32_t* to = out + i * stride + b * kDotBlockRows;
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(to), lo[i]);
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(to + 8), hi[i]);
    }
  }
}

// C blocks from `blocked`, fixed sizes so that every sum stays in a register.
template <int Q, int C>
__attribute__((target("avx512f,avx512bw,avx512vnni"))) void codeDotsVnniChunk(
    const std::int16_t* queries, const std::int16_t* blocked, int dim, std::int32_t* out,
    std::size_t stride) {
  const int pairs = dim / 2;
  __m512i sums[Q][C];
  for (int i = 0; i < Q; ++i)
    for (int j = 0; j < C; ++j) sums[i][j] = _mm512_setzero_si512();
  for (int p = 0; p < pairs; ++p) {
    __m512i codes[C];
    for (int j = 0; j < C; ++j)
      codes[j] =
          _mm512_loadu_si512(blocked + (static_cast<std::size_t>(j) * pairs + p) * kPairCodes);
    for (int i = 0; i < Q; ++i) {
      const __m512i q = _mm512_set1_epi32(pairOf(queries + static_cast<std::size_t>(i) * dim, p));
      for (int j = 0; j < C; ++j) sums[i][j] = _mm512_dpwssd_epi32(sums[i][j], q, codes[j]);
    }
  }
  for (int i = 0; i < Q; ++i)
    for (int j = 0; j < C; ++j)
      _mm512_storeu_si512(out + i * stride + j * kDotBlockRows, sums[i][j]);
}

template <int Q>
void codeDotsVnni(const std::int16_t* queries, const std::int16_t* blocked, int blocks, int dim,
                  std::int32_t* out, std::size_t stride) {
  constexpr int kChunk = 4;
  const std::size_t block_codes = static_cast<std::size_t>(dim / 2) * kPairCodes;
  int b = 0;
  for (; b + kChunk <= blocks; b += kChunk)
    codeDotsVnniChunk<Q, kChunk>(queries, blocked + b * block_codes, dim, out + b * kDotBlockRows,
                                 stride);
  for (; b < blocks; ++b)
    codeDotsVnniChunk<Q, 1>(queries, blocked + b * block_codes, dim, out + b * kDotBlockRows,
                            stride);
}

using Kernel = void (*)(const std::int16_t*, const std::int16_t*, int, int, std::int32_t*,
                        std::size_t);
constexpr Kernel kAvx2Kernels[kDotQueryRows] = {codeDotsAvx2<1>, codeDotsAvx2<2>, codeDotsAvx2<3>,
                                                codeDotsAvx2<4>};
constexpr Kernel kVnniKernels[kDotQueryRows] = {codeDotsVnni<1>, codeDotsVnni<2>, codeDotsVnni<3>,
                                                codeDotsVnni<4>};
#endif

}  // namespace

std::vector<std::int16_t> blockCodes(const std::int16_t* codes, int rows, int dim) {
  const int blocks = (rows + kDotBlockRows - 1) / kDotBlockRows;
  const int pairs = dim / 2;
  std::vector<std::int16_t> out(static_cast<std::size_t>(blocks) * pairs * kPairCodes, 0);
  for (int r = 0; r < rows; ++r) {
    const std::int16_t* row = codes + static_cast<std::size_t>(r) * dim;
    const std::size_t block = static_cast<std::size_t>(r / kDotBlockRows);
    const std::size_t lane = static_cast<std::size_t>(r % kDotBlockRows) * 2;
    for (int p = 0; p < pairs; ++p) {
      std::int16_t* to = out.data() + (block * pairs + p) * kPairCodes + lane;
      to[0] = row[2 * p];
      to[1] = row[2 * p + 1];
    }
  }
  return out;
}

bool dotKernelAvailable(DotKernel kernel) {
  switch (kernel) {
#if defined(PLACEDB_CODE_DOTS_X86)
    case DotKernel::kVnni: {
      static const bool vnni = simdAllows(SimdLevel::kAvx512Vnni);
      return vnni;
    }
    case DotKernel::kAvx2: {
      static const bool avx2 = simdAllows(SimdLevel::kAvx2);
      return avx2;
    }
#endif
    case DotKernel::kPlain:
      return true;
    default:
      return false;
  }
}

void codeDots(DotKernel kernel, const std::int16_t* queries, int count, const std::int16_t* blocked,
              int rows, int dim, std::int32_t* out, std::size_t stride) {
  const int blocks = (rows + kDotBlockRows - 1) / kDotBlockRows;
  if (count < 1 || count > kDotQueryRows) return;
  switch (kernel) {
#if defined(PLACEDB_CODE_DOTS_X86)
    case DotKernel::kVnni:
      return kVnniKernels[count - 1](queries, blocked, blocks, dim, out, stride);
    case DotKernel::kAvx2:
      return kAvx2Kernels[count - 1](queries, blocked, blocks, dim, out, stride);
#endif
    default:
      return codeDotsPlain(queries, count, blocked, blocks, dim, out, stride);
  }
}

void codeDots(const std::int16_t* queries, int count, const std::int16_t* blocked, int rows,
              int dim, std::int32_t* out, std::size_t stride) {
  static const DotKernel best = dotKernelAvailable(DotKernel::kVnni)   ? DotKernel::kVnni
                                : dotKernelAvailable(DotKernel::kAvx2) ? DotKernel::kAvx2
                                                                       : DotKernel::kPlain;
  codeDots(best, queries, count, blocked, rows, dim, out, stride);
}

}  // namespace placedb
