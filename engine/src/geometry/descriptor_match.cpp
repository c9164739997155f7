#include "geometry/descriptor_match.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/core/hal/hal.hpp>
#include <utility>

#include "features/cpu_support.h"
#include "geometry/descriptor_dots.h"
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

// Keeps the two smallest values seen in (first, second).
void offer(double v, double& first, double& second) {
  second = std::min(second, std::max(first, v));
  first = std::min(first, v);
}

// The two smallest values (with repeats), without branches: the candidates' order is
// unpredictable. Four independent chains, merged at the end, keep the dependency on the
// previous value from setting the pace.
std::pair<double, double> twoSmallest(const double* values, int count) {
  double first[4] = {kInf, kInf, kInf, kInf}, second[4] = {kInf, kInf, kInf, kInf};
  int i = 0;
  for (; i + 4 <= count; i += 4)
    for (int lane = 0; lane < 4; ++lane) offer(values[i + lane], first[lane], second[lane]);
  for (; i < count; ++i) offer(values[i], first[0], second[0]);
  // The two smallest of all are among each chain's two smallest.
  double a1 = kInf, a2 = kInf;
  for (int lane = 0; lane < 4; ++lane) {
    offer(first[lane], a1, a2);
    offer(second[lane], a1, a2);
  }
  return {a1, a2};
}

// Every candidate's squared distance between the codes' vectors, (|q|^2 + |c|^2) - 2 q.c, and
// the two smallest of them.
std::pair<double, double> codeDistances(double q_norm_sq, double q_unit2, const double* c_norm_sq,
                                        const double* c_unit, const std::int32_t* products,
                                        int count, double* out) {
  for (int c = 0; c < count; ++c)
    out[c] = q_norm_sq + c_norm_sq[c] - q_unit2 * c_unit[c] * products[c];
  return twoSmallest(out, count);
}

#if defined(__GNUC__) && defined(__x86_64__)
#define PLACEDB_CODE_DISTANCES_AVX2 1
// The same, four candidates at a time: the same operations on each, so the same values (AVX2
// alone has no fused multiply-add to round differently), and four chains of the two smallest.
__attribute__((target("avx2"))) std::pair<double, double> codeDistancesAvx2(
    double q_norm_sq, double q_unit2, const double* c_norm_sq, const double* c_unit,
    const std::int32_t* products, int count, double* out) {
  const __m256d q_sq = _mm256_set1_pd(q_norm_sq), q_u2 = _mm256_set1_pd(q_unit2);
  __m256d first = _mm256_set1_pd(kInf), second = first;
  int c = 0;
  for (; c + 4 <= count; c += 4) {
    const __m256d product =
        _mm256_cvtepi32_pd(_mm_loadu_si128(reinterpret_cast<const __m128i*>(products + c)));
    const __m256d scaled = _mm256_mul_pd(_mm256_mul_pd(q_u2, _mm256_loadu_pd(c_unit + c)), product);
    const __m256d v = _mm256_sub_pd(_mm256_add_pd(q_sq, _mm256_loadu_pd(c_norm_sq + c)), scaled);
    _mm256_storeu_pd(out + c, v);
    second = _mm256_min_pd(second, _mm256_max_pd(first, v));
    first = _mm256_min_pd(first, v);
  }
  double firsts[4], seconds[4];
  _mm256_storeu_pd(firsts, first);
  _mm256_storeu_pd(seconds, second);
  double a1 = kInf, a2 = kInf;
  for (int lane = 0; lane < 4; ++lane) {
    offer(firsts[lane], a1, a2);
    offer(seconds[lane], a1, a2);
  }
  for (; c < count; ++c) {
    out[c] = q_norm_sq + c_norm_sq[c] - q_unit2 * c_unit[c] * products[c];
    offer(out[c], a1, a2);
  }
  return {a1, a2};
}
#endif

// A row's values as the full comparison sees them: the float rows, or the stored codes decoded
// with decodeDescriptors()'s own expression.
const float* valuesOf(const DescriptorSide& side, int row, float* buffer) {
  if (side.values && !side.values->empty()) return side.values->ptr<float>(row);
  const DescriptorCodes& c = *side.codes;
  const float scale = c.stored_scale[static_cast<std::size_t>(row)];
  if (!c.codes.empty()) {
    const std::int16_t* code = c.codes.data() + static_cast<std::size_t>(row) * c.dim;
    for (int k = 0; k < c.dim; ++k) buffer[k] = static_cast<float>(code[k]) * scale / 127.f;
  } else {
    blockedRow(c.blocked.data(), c.dim, row, buffer);  // the codes, exactly, as floats
    for (int k = 0; k < c.dim; ++k) buffer[k] = buffer[k] * scale / 127.f;
  }
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
  std::vector<std::int16_t> codes(static_cast<std::size_t>(out.rows) * dim);
  out.unit.resize(static_cast<std::size_t>(out.rows));
  out.norm.resize(static_cast<std::size_t>(out.rows));
  out.error.resize(static_cast<std::size_t>(out.rows));
  out.stored_scale.resize(static_cast<std::size_t>(out.rows));
  for (int r = 0; r < out.rows; ++r) {
    const std::uint8_t* in = bytes.data() + static_cast<std::size_t>(r) * row_bytes;
    float scale = 0.f;
    std::memcpy(&scale, in, sizeof(float));
    std::int16_t* code = codes.data() + static_cast<std::size_t>(r) * dim;
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
  // A stored location is only ever a candidate: its codes are kept in the candidate layout alone.
  if (dim % 2 == 0) {
    out.blocked = blockCodes(codes.data(), out.rows, dim);
  } else {
    out.codes = std::move(codes);
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
                      cc->dim == dim && dim % 2 == 0 && !qc->codes.empty() &&
                      (!cc->blocked.empty() || !cc->codes.empty()) &&
                      static_cast<std::int64_t>(dim) * qc->levels * cc->levels <
                          std::numeric_limits<std::int32_t>::max();
  if (!usable || nq < 2 || nc < 2) return ratioMatchesBruteForce(query, candidate, ratio_sq);
  std::vector<std::int16_t> own_blocks;  // a candidate made by quantiseDescriptors()
  if (cc->blocked.empty()) own_blocks = blockCodes(cc->codes.data(), nc, dim);
  const std::int16_t* blocked = cc->blocked.empty() ? own_blocks.data() : cc->blocked.data();

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
  // Products of kDotQueryRows query rows at a time, a row of `stride` each.
  const std::size_t stride =
      static_cast<std::size_t>((nc + kDotBlockRows - 1) / kDotBlockRows * kDotBlockRows);
  std::vector<std::int32_t> products(stride * kDotQueryRows);
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
    if (q % kDotQueryRows == 0)
      codeDots(qc->codes.data() + qi * static_cast<std::size_t>(dim),
               std::min(kDotQueryRows, nq - q), blocked, nc, dim, products.data(), stride);
    const std::int32_t* product = products.data() + (q % kDotQueryRows) * stride;
    RatioMatch m;
    m.query = q;
    const float* q_values = valuesOf(query, q, q_buffer.data());
    if (!std::isfinite(qc->error[qi]) || !(qc->norm[qi] < kLargestNorm)) {
      nearestTwo(q_values, values(), nullptr, &m);
      if (keep(m, ratio_sq)) out.push_back(m);
      continue;
    }
    // Squared distances between the codes' vectors, and the two smallest.
    const double q_norm_sq = qc->norm[qi] * qc->norm[qi], q_unit2 = 2.0 * qc->unit[qi];
#if defined(PLACEDB_CODE_DISTANCES_AVX2)
    static const bool avx2 = simdAllows(SimdLevel::kAvx2);
    const auto [a1, a2] = avx2 ? codeDistancesAvx2(q_norm_sq, q_unit2, c_norm_sq.data(),
                                                   cc->unit.data(), product, nc, approx.data())
                               : codeDistances(q_norm_sq, q_unit2, c_norm_sq.data(),
                                               cc->unit.data(), product, nc, approx.data());
#else
    const auto [a1, a2] = codeDistances(q_norm_sq, q_unit2, c_norm_sq.data(), cc->unit.data(),
                                        product, nc, approx.data());
#endif
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
