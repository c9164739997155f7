#include "geometry/descriptor_match.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/core/hal/hal.hpp>
#include <utility>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#endif

namespace placedb {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Float arithmetic moves a computed distance by a few parts per million of the vectors'
// lengths at most (64 rounded squares summed; the decode's two roundings); the bounds allow
// ten times that. Values so small that their squares are denormal lose more, absolutely: at
// most some hundred steps of 1.4e-45 in a squared distance, ~5e-22 in a distance, which the
// absolute floor covers.
constexpr double kRelativeSlack = 1e-5;
constexpr double kAbsoluteSlack = 1e-20;
// Beyond this length a float square can overflow: such rows are compared in full.
constexpr double kLargestNorm = 1e15;

// Exact integer sums: |code| <= levels on both sides and dim * levels_q * levels_c < 2^31, so
// no order of summation can overflow or round, and every instruction set gives the same sums.
std::int32_t dot(const std::int16_t* a, const std::int16_t* b, int n) {
  std::int32_t s = 0;
  for (int k = 0; k < n; ++k) s += static_cast<std::int32_t>(a[k]) * b[k];
  return s;
}

#if defined(__GNUC__) && defined(__x86_64__)
#define PLACEDB_DOTS_AVX2 1
// Twice the SSE2 loop's width where the CPU has it; the sums are exact integers either way.
__attribute__((target("avx2"))) int dotsAvx2(const std::int16_t* q, const std::int16_t* c, int rows,
                                             int dim, std::int32_t* out) {
  const std::size_t stride = static_cast<std::size_t>(dim);
  int r = 0;
  for (; r + 4 <= rows; r += 4) {
    const std::int16_t* c0 = c + static_cast<std::size_t>(r) * stride;
    __m256i s0 = _mm256_setzero_si256(), s1 = s0, s2 = s0, s3 = s0;
    const std::int16_t *c1 = c0 + stride, *c2 = c1 + stride, *c3 = c2 + stride;
    for (int k = 0; k < dim; k += 16) {
      const __m256i qv = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(q + k));
      // (A lambda would not inherit the target attribute.)
      s0 = _mm256_add_epi32(
          s0, _mm256_madd_epi16(qv, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(c0 + k))));
      s1 = _mm256_add_epi32(
          s1, _mm256_madd_epi16(qv, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(c1 + k))));
      s2 = _mm256_add_epi32(
          s2, _mm256_madd_epi16(qv, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(c2 + k))));
      s3 = _mm256_add_epi32(
          s3, _mm256_madd_epi16(qv, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(c3 + k))));
    }
    // Pairwise adds leave each half with the four rows' partial sums; the halves add up.
    const __m256i t = _mm256_hadd_epi32(_mm256_hadd_epi32(s0, s1), _mm256_hadd_epi32(s2, s3));
    const __m128i sum = _mm_add_epi32(_mm256_castsi256_si128(t), _mm256_extracti128_si256(t, 1));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out + r), sum);
  }
  return r;
}
#endif

// The dot products of one query row with `rows` consecutive candidate rows.
void dots(const std::int16_t* q, const std::int16_t* c, int rows, int dim, std::int32_t* out) {
  int r = 0;
#if defined(PLACEDB_DOTS_AVX2)
  static const bool avx2 = __builtin_cpu_supports("avx2");
  if (avx2 && dim % 16 == 0) r = dotsAvx2(q, c, rows, dim, out);
#endif
#if defined(__SSE2__)
  // Four candidate rows at a time share each load of the query and one final reduction.
  if (dim % 8 == 0) {
    const std::size_t stride = static_cast<std::size_t>(dim);
    for (; r + 4 <= rows; r += 4) {
      const std::int16_t* c0 = c + static_cast<std::size_t>(r) * stride;
      __m128i s0 = _mm_setzero_si128(), s1 = s0, s2 = s0, s3 = s0;
      for (int k = 0; k < dim; k += 8) {
        const __m128i qv = _mm_loadu_si128(reinterpret_cast<const __m128i*>(q + k));
        const auto at = [&](std::size_t row) {
          return _mm_loadu_si128(reinterpret_cast<const __m128i*>(c0 + row * stride + k));
        };
        s0 = _mm_add_epi32(s0, _mm_madd_epi16(qv, at(0)));
        s1 = _mm_add_epi32(s1, _mm_madd_epi16(qv, at(1)));
        s2 = _mm_add_epi32(s2, _mm_madd_epi16(qv, at(2)));
        s3 = _mm_add_epi32(s3, _mm_madd_epi16(qv, at(3)));
      }
      // Transpose-and-add: lane i of the result is the sum of s_i's four lanes.
      const __m128i t01 = _mm_add_epi32(_mm_unpacklo_epi32(s0, s1), _mm_unpackhi_epi32(s0, s1));
      const __m128i t23 = _mm_add_epi32(_mm_unpacklo_epi32(s2, s3), _mm_unpackhi_epi32(s2, s3));
      const __m128i sum = _mm_add_epi32(_mm_unpacklo_epi64(t01, t23), _mm_unpackhi_epi64(t01, t23));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(out + r), sum);
    }
  }
#endif
  for (; r < rows; ++r) out[r] = dot(q, c + static_cast<std::size_t>(r) * dim, dim);
}

// Keeps the two smallest values seen in (first, second).
void offer(double v, double& first, double& second) {
  second = std::min(second, std::max(first, v));
  first = std::min(first, v);
}

// The two smallest values (with repeats), without branches: the candidates' order is
// unpredictable. Four independent chains, merged at the end, keep the dependency on the
// previous value from setting the pace.
std::pair<double, double> twoSmallest(const std::vector<double>& values) {
  double first[4] = {kInf, kInf, kInf, kInf}, second[4] = {kInf, kInf, kInf, kInf};
  std::size_t i = 0;
  for (; i + 4 <= values.size(); i += 4)
    for (int lane = 0; lane < 4; ++lane) offer(values[i + lane], first[lane], second[lane]);
  for (; i < values.size(); ++i) offer(values[i], first[0], second[0]);
  // The two smallest of all are among each chain's two smallest.
  double a1 = kInf, a2 = kInf;
  for (int lane = 0; lane < 4; ++lane) {
    offer(first[lane], a1, a2);
    offer(second[lane], a1, a2);
  }
  return {a1, a2};
}

// A row's values as the full comparison sees them: the float rows, or the stored codes decoded
// with decodeDescriptors()'s own expression.
const float* valuesOf(const DescriptorSide& side, int row, float* buffer) {
  if (side.values && !side.values->empty()) return side.values->ptr<float>(row);
  const DescriptorCodes& c = *side.codes;
  const std::int16_t* code = c.codes.data() + static_cast<std::size_t>(row) * c.dim;
  const float scale = c.stored_scale[static_cast<std::size_t>(row)];
  for (int k = 0; k < c.dim; ++k) buffer[k] = static_cast<float>(code[k]) * scale / 127.f;
  return buffer;
}

int dimOf(const DescriptorSide& side) {
  if (side.values && !side.values->empty()) return side.values->cols;
  return side.codes ? side.codes->dim : 0;
}

// The candidate rows decoded once, for comparisons that visit them all.
cv::Mat allValues(const DescriptorSide& side) {
  if (side.values && !side.values->empty()) return *side.values;
  cv::Mat out(side.rows(), dimOf(side), CV_32F);
  for (int r = 0; r < out.rows; ++r) {
    const float* row = valuesOf(side, r, out.ptr<float>(r));
    if (row != out.ptr<float>(r)) std::memcpy(out.ptr<float>(r), row, sizeof(float) * out.cols);
  }
  return out;
}

// The full comparison of one query row with the candidate rows `which` (ascending), or with
// all of them when `which` is null.
void nearestTwo(const float* q, const cv::Mat& candidate, const std::vector<int>* which,
                RatioMatch* m) {
  float d1 = std::numeric_limits<float>::max(), d2 = d1;
  int best = -1;
  const int count = which ? static_cast<int>(which->size()) : candidate.rows;
  for (int i = 0; i < count; ++i) {
    const int c = which ? (*which)[static_cast<std::size_t>(i)] : i;
    const float d = cv::hal::normL2Sqr_(q, candidate.ptr<float>(c), candidate.cols);
    if (d < d1) {
      d2 = d1;
      d1 = d;
      best = c;
    } else if (d < d2) {
      d2 = d;
    }
  }
  m->candidate = best;
  m->d1 = d1;
  m->d2 = d2;
}

bool keep(const RatioMatch& m, float ratio_sq) {
  return m.candidate >= 0 && m.d1 < ratio_sq * m.d2;
}

}  // namespace

int DescriptorSide::rows() const {
  if (values && !values->empty()) return values->rows;
  return codes ? codes->rows : 0;
}

DescriptorCodes quantiseDescriptors(const cv::Mat& descriptors, int levels) {
  DescriptorCodes out;
  if (descriptors.empty() || descriptors.type() != CV_32F || levels < 1 || levels > 32767)
    return out;
  out.rows = descriptors.rows;
  out.dim = descriptors.cols;
  out.levels = levels;
  out.codes.assign(static_cast<std::size_t>(out.rows) * out.dim, 0);
  out.unit.assign(static_cast<std::size_t>(out.rows), 0.0);
  out.norm.assign(static_cast<std::size_t>(out.rows), 0.0);
  out.error.assign(static_cast<std::size_t>(out.rows), 0.0);
  for (int r = 0; r < out.rows; ++r) {
    const float* row = descriptors.ptr<float>(r);
    std::int16_t* code = out.codes.data() + static_cast<std::size_t>(r) * out.dim;
    double largest = 0;
    bool finite = true;
    for (int k = 0; k < out.dim; ++k) {
      finite = finite && std::isfinite(row[k]);
      largest = std::max(largest, std::abs(static_cast<double>(row[k])));
    }
    if (!finite) {
      out.error[static_cast<std::size_t>(r)] = kInf;
      continue;
    }
    if (largest == 0) continue;
    const double unit = largest / levels;
    double norm = 0, error = 0;
    for (int k = 0; k < out.dim; ++k) {
      const double c = std::clamp(std::round(row[k] / unit), -double(levels), double(levels));
      code[k] = static_cast<std::int16_t>(c);
      norm += (c * unit) * (c * unit);
      error += (row[k] - c * unit) * (row[k] - c * unit);
    }
    out.unit[static_cast<std::size_t>(r)] = unit;
    out.norm[static_cast<std::size_t>(r)] = std::sqrt(norm);
    // The double sums above are off by far less than the slack the matcher adds.
    out.error[static_cast<std::size_t>(r)] = std::sqrt(error);
  }
  return out;
}

DescriptorCodes storedDescriptorCodes(const std::vector<std::uint8_t>& bytes, int dim) {
  DescriptorCodes out;
  const std::size_t row_bytes = sizeof(float) + static_cast<std::size_t>(std::max(dim, 0));
  if (dim <= 0 || bytes.size() % row_bytes != 0) return out;
  out.rows = static_cast<int>(bytes.size() / row_bytes);
  out.dim = dim;
  out.levels = 127;  // an int8 code can be -128 too, but encodeDescriptors never writes it
  out.stored = true;
  out.codes.resize(static_cast<std::size_t>(out.rows) * dim);
  out.unit.resize(static_cast<std::size_t>(out.rows));
  out.norm.resize(static_cast<std::size_t>(out.rows));
  out.error.resize(static_cast<std::size_t>(out.rows));
  out.stored_scale.resize(static_cast<std::size_t>(out.rows));
  for (int r = 0; r < out.rows; ++r) {
    const std::uint8_t* in = bytes.data() + static_cast<std::size_t>(r) * row_bytes;
    float scale = 0.f;
    std::memcpy(&scale, in, sizeof(float));
    std::int16_t* code = out.codes.data() + static_cast<std::size_t>(r) * dim;
    double sum = 0;
    bool in_range = true;
    for (int k = 0; k < dim; ++k) {
      code[k] = static_cast<std::int8_t>(in[sizeof(float) + k]);
      in_range = in_range && code[k] >= -127;
      sum += double(code[k]) * code[k];
    }
    const double unit = static_cast<double>(scale) / 127.0;
    const std::size_t i = static_cast<std::size_t>(r);
    out.stored_scale[i] = scale;
    out.unit[i] = unit;
    out.norm[i] = std::abs(unit) * std::sqrt(sum);
    // The decode's float multiply and divide each round to 2^-24 of the value: a bound well
    // under the matcher's slack. Bytes from elsewhere (NaN scale, -128) are compared in full.
    out.error[i] = std::isfinite(scale) && in_range ? 0.0 : kInf;
  }
  return out;
}

std::vector<RatioMatch> ratioMatchesBruteForce(const DescriptorSide& query,
                                               const DescriptorSide& candidate, float ratio_sq) {
  std::vector<RatioMatch> out;
  if (query.rows() < 2 || candidate.rows() < 2 || dimOf(query) != dimOf(candidate)) return out;
  const cv::Mat c = allValues(candidate);
  std::vector<float> buffer(static_cast<std::size_t>(dimOf(query)));
  for (int q = 0; q < query.rows(); ++q) {
    RatioMatch m;
    m.query = q;
    nearestTwo(valuesOf(query, q, buffer.data()), c, nullptr, &m);
    if (keep(m, ratio_sq)) out.push_back(m);
  }
  return out;
}

std::vector<RatioMatch> ratioMatches(const DescriptorSide& query, const DescriptorSide& candidate,
                                     float ratio_sq) {
  const int nq = query.rows(), nc = candidate.rows(), dim = dimOf(query);
  const DescriptorCodes* qc = query.codes;
  const DescriptorCodes* cc = candidate.codes;
  const bool usable = qc && cc && qc->rows == nq && cc->rows == nc && qc->dim == dim &&
                      cc->dim == dim &&
                      static_cast<std::int64_t>(dim) * qc->levels * cc->levels <
                          std::numeric_limits<std::int32_t>::max();
  if (!usable || nq < 2 || nc < 2) return ratioMatchesBruteForce(query, candidate, ratio_sq);

  // The candidate side's worst case, for every pair alike.
  double c_error = 0, c_norm = 0;
  std::vector<double> c_norm_sq(static_cast<std::size_t>(nc));
  for (int c = 0; c < nc; ++c) {
    const std::size_t i = static_cast<std::size_t>(c);
    c_error = std::max(c_error, cc->error[i]);
    c_norm = std::max(c_norm, cc->norm[i]);
    c_norm_sq[i] = cc->norm[i] * cc->norm[i];
  }
  if (!std::isfinite(c_error) || !(c_norm < kLargestNorm))
    return ratioMatchesBruteForce(query, candidate, ratio_sq);

  std::vector<RatioMatch> out;
  std::vector<double> approx(static_cast<std::size_t>(nc));
  std::vector<std::int32_t> products(static_cast<std::size_t>(nc));
  std::vector<int> which;
  which.reserve(static_cast<std::size_t>(nc));
  std::vector<float> q_buffer(static_cast<std::size_t>(dim));
  cv::Mat c_values;  // decoded on first need: most query rows never compare in full
  const auto values = [&]() -> const cv::Mat& {
    if (c_values.empty()) c_values = allValues(candidate);
    return c_values;
  };
  for (int q = 0; q < nq; ++q) {
    const std::size_t qi = static_cast<std::size_t>(q);
    RatioMatch m;
    m.query = q;
    const float* q_values = valuesOf(query, q, q_buffer.data());
    if (!std::isfinite(qc->error[qi]) || !(qc->norm[qi] < kLargestNorm)) {
      nearestTwo(q_values, values(), nullptr, &m);
      if (keep(m, ratio_sq)) out.push_back(m);
      continue;
    }
    // Squared distances between the codes' vectors, and the two smallest.
    const std::int16_t* q_code = qc->codes.data() + qi * static_cast<std::size_t>(dim);
    const double q_norm_sq = qc->norm[qi] * qc->norm[qi], q_unit2 = 2.0 * qc->unit[qi];
    dots(q_code, cc->codes.data(), nc, dim, products.data());
    for (int c = 0; c < nc; ++c) {
      const std::size_t ci = static_cast<std::size_t>(c);
      approx[ci] = q_norm_sq + c_norm_sq[ci] - q_unit2 * cc->unit[ci] * products[ci];
    }
    const auto [a1, a2] = twoSmallest(approx);
    // A pair's distance of the values lies within `h` of its codes' distance (the triangle
    // inequality, both roundings, float slack); `delta` is the double sum's own error.
    const double lengths = qc->norm[qi] + qc->error[qi] + c_norm + c_error;
    const double h = qc->error[qi] + c_error + kRelativeSlack * lengths + kAbsoluteSlack;
    const double delta = 1e-12 * lengths * lengths + kAbsoluteSlack;
    const double second_at_most = std::sqrt(a2 + delta) + h;
    const double nearest_at_least = std::sqrt(std::max(0.0, a1 - delta)) - h;
    // The nearest cannot be closer than ratio_sq times the second: the ratio test fails (the
    // margins cover the rounding of the float product, relative and denormal).
    if (nearest_at_least > 0 &&
        nearest_at_least * nearest_at_least >=
            double(ratio_sq) * second_at_most * second_at_most * (1 + 1e-4) +
                kAbsoluteSlack * kAbsoluteSlack)
      continue;
    // Rows that may be nearest or second nearest: their lowest possible distance does not
    // exceed the second-highest highest possible one.
    const double reach = second_at_most + h;
    const double limit = reach * reach * (1 + 1e-9) + delta;
    which.clear();
    for (int c = 0; c < nc; ++c)
      if (approx[static_cast<std::size_t>(c)] <= limit) which.push_back(c);
    nearestTwo(q_values, values(), &which, &m);
    if (keep(m, ratio_sq)) out.push_back(m);
  }
  return out;
}

}  // namespace placedb
