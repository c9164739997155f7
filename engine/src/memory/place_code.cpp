#include "memory/place_code.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#define PLACEDB_CODE_DOTS_AVX2 1
#endif

#include "features/cpu_support.h"
#include "placedb/error.h"

namespace placedb {
namespace {

constexpr int kLloydIterations = 10;
constexpr std::uint64_t kProjectionSeed = 0x5eedc0dedb1ace01ULL;

// splitmix64: the projection must be the same bits on every run and every standard library,
// which <random>'s distributions do not promise.
std::uint64_t nextRandom(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

float squaredDistance(const float* a, const float* b, int dim) {
  float d = 0;
  for (int i = 0; i < dim; ++i) {
    const float t = a[i] - b[i];
    d += t * t;
  }
  return d;
}

int nearestCentre(const cv::Mat& centres, const float* row) {
  int best = 0;
  float best_distance = std::numeric_limits<float>::max();
  for (int c = 0; c < centres.rows; ++c) {
    const float d = squaredDistance(centres.ptr<float>(c), row, centres.cols);
    if (d < best_distance) {
      best_distance = d;
      best = c;
    }
  }
  return best;
}

}  // namespace

PlaceCoder::PlaceCoder(cv::Mat centres, int code_dim)
    : dim_(centres.cols), code_dim_(code_dim), centres_(std::move(centres)) {
  makeProjection();
  const auto k = static_cast<std::size_t>(centres_.rows);
  centres_by_dim_.resize(k * static_cast<std::size_t>(dim_));
  for (int c = 0; c < centres_.rows; ++c)
    for (int j = 0; j < dim_; ++j) centres_by_dim_[j * k + c] = centres_.ptr<float>(c)[j];
}

int PlaceCoder::nearestCentreOf(const float* row, float* distances) const {
  // nearestCentre()'s sums, every centre's at once: each centre's still adds its dimensions in
  // order, so the same distances, and the loop over centres vectorises.
  const int k = centres_.rows;
  std::fill(distances, distances + k, 0.0f);
  for (int j = 0; j < dim_; ++j) {
    const float* column = centres_by_dim_.data() + static_cast<std::size_t>(j) * k;
    const float x = row[j];
    for (int c = 0; c < k; ++c) {
      const float t = column[c] - x;
      distances[c] += t * t;
    }
  }
  int best = 0;
  float best_distance = std::numeric_limits<float>::max();
  for (int c = 0; c < k; ++c) {
    if (distances[c] < best_distance) {
      best_distance = distances[c];
      best = c;
    }
  }
  return best;
}

void PlaceCoder::makeProjection() {
  const std::size_t in = static_cast<std::size_t>(centres_.rows) * static_cast<std::size_t>(dim_);
  const auto outputs = static_cast<std::size_t>(code_dim_);
  signs_.resize(outputs * in);
  // The random stream fills the matrix output by output (row o, then input i); it is stored
  // input by input, so that encode() adds one input to every output at a time.
  std::uint64_t state = kProjectionSeed;
  for (std::size_t k = 0; k < signs_.size(); k += 64) {
    const std::uint64_t bits = nextRandom(state);
    for (std::size_t b = 0; b < 64 && k + b < signs_.size(); ++b) {
      const std::size_t o = (k + b) / in, i = (k + b) % in;
      signs_[i * outputs + o] = (bits >> b) & 1 ? 1 : -1;
    }
  }
}

PlaceCoder PlaceCoder::train(const cv::Mat& descriptors, const PlaceCodeSettings& settings) {
  if (descriptors.empty() || descriptors.type() != CV_32F || settings.centres < 1 ||
      settings.code_dim < 1)
    throw Error(ErrorCode::kInvalidArgument,
                "place codes need float descriptors, at least one centre and one code value");
  const int k = settings.centres;
  const int dim = descriptors.cols;
  const int n = descriptors.rows;
  cv::Mat centres(k, dim, CV_32F);

  // Farthest-point seeding from the strongest keypoint (row 0): no random draw to reproduce.
  std::vector<float> nearest(static_cast<std::size_t>(n), std::numeric_limits<float>::max());
  int chosen = 0;
  for (int c = 0; c < k; ++c) {
    descriptors.row(chosen % n).copyTo(centres.row(c));
    int farthest = 0;
    float far_distance = -1;
    for (int i = 0; i < n; ++i) {
      const float d = squaredDistance(descriptors.ptr<float>(i), centres.ptr<float>(c), dim);
      nearest[i] = std::min(nearest[i], d);
      if (nearest[i] > far_distance) {
        far_distance = nearest[i];
        farthest = i;
      }
    }
    chosen = far_distance > 0 ? farthest : c + 1;  // all rows covered: repeat rows in order
  }

  std::vector<int> assignment(static_cast<std::size_t>(n), -1);
  for (int iteration = 0; iteration < kLloydIterations; ++iteration) {
    bool changed = false;
    for (int i = 0; i < n; ++i) {
      const int c = nearestCentre(centres, descriptors.ptr<float>(i));
      changed = changed || c != assignment[i];
      assignment[i] = c;
    }
    if (!changed) break;
    cv::Mat sums = cv::Mat::zeros(k, dim, CV_64F);
    std::vector<int> counts(static_cast<std::size_t>(k), 0);
    for (int i = 0; i < n; ++i) {
      const float* row = descriptors.ptr<float>(i);
      double* sum = sums.ptr<double>(assignment[i]);
      for (int j = 0; j < dim; ++j) sum[j] += row[j];
      counts[assignment[i]] += 1;
    }
    for (int c = 0; c < k; ++c) {
      if (counts[c] == 0) continue;  // an empty cluster keeps its centre
      for (int j = 0; j < dim; ++j)
        centres.at<float>(c, j) = static_cast<float>(sums.at<double>(c, j) / counts[c]);
    }
  }
  return PlaceCoder(centres, settings.code_dim);
}

std::vector<std::uint8_t> PlaceCoder::toBytes() const {
  // Layout: int32 K, int32 dim, int32 code_dim, then K x dim floats, little-endian as in RAM.
  const std::int32_t header[3] = {centres_.rows, dim_, code_dim_};
  std::vector<std::uint8_t> out(sizeof(header) + centres_.total() * sizeof(float));
  std::memcpy(out.data(), header, sizeof(header));
  std::memcpy(out.data() + sizeof(header), centres_.ptr<float>(), centres_.total() * sizeof(float));
  return out;
}

PlaceCoder PlaceCoder::fromBytes(const std::vector<std::uint8_t>& bytes, int dim) {
  std::int32_t header[3] = {0, 0, 0};
  if (bytes.size() >= sizeof(header)) std::memcpy(header, bytes.data(), sizeof(header));
  const auto [k, stored_dim, code_dim] = header;
  if (k < 1 || k > 4096 || stored_dim != dim || code_dim < 1 || code_dim > 65536 ||
      bytes.size() != sizeof(header) + std::size_t(k) * std::size_t(dim) * sizeof(float))
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("place-code centres do not fit {}-value descriptors", dim));
  cv::Mat centres(k, dim, CV_32F);
  std::memcpy(centres.ptr<float>(), bytes.data() + sizeof(header), centres.total() * sizeof(float));
  for (std::size_t i = 0; i < centres.total(); ++i)
    if (!std::isfinite(centres.ptr<float>()[i]))
      throw Error(ErrorCode::kInvalidArgument, "place-code centres hold a non-finite value");
  return PlaceCoder(centres, code_dim);
}

std::vector<std::int8_t> PlaceCoder::encode(const cv::Mat& descriptors) const {
  const int k = centres_.rows;
  std::vector<float> vlad(static_cast<std::size_t>(k) * static_cast<std::size_t>(dim_), 0.0f);
  std::vector<float> distances(static_cast<std::size_t>(k));
  for (int i = 0; i < descriptors.rows; ++i) {
    const float* row = descriptors.ptr<float>(i);
    const int c = nearestCentreOf(row, distances.data());
    const float* centre = centres_.ptr<float>(c);
    float* block = vlad.data() + static_cast<std::size_t>(c) * dim_;
    for (int j = 0; j < dim_; ++j) block[j] += row[j] - centre[j];
  }
  for (int c = 0; c < k; ++c) {
    float* block = vlad.data() + static_cast<std::size_t>(c) * dim_;
    float norm = 0;
    for (int j = 0; j < dim_; ++j) norm += block[j] * block[j];
    if (norm <= 0) continue;
    const float inv = 1.0f / std::sqrt(norm);
    for (int j = 0; j < dim_; ++j) {
      const float v = block[j] * inv;
      block[j] = v < 0 ? -std::sqrt(-v) : std::sqrt(v);
    }
  }
  // Each output is the sum of its inputs in input order, as the straightforward loop over one
  // output at a time adds them; taking every output at once, one input at a time, keeps that
  // order and lets the compiler add many outputs per instruction (a sum over one output cannot
  // be reordered).
  std::vector<float> projected(static_cast<std::size_t>(code_dim_), 0.0f);
  for (std::size_t i = 0; i < vlad.size(); ++i) {
    const std::int8_t* sign = signs_.data() + i * static_cast<std::size_t>(code_dim_);
    const float v = vlad[i];
    for (int o = 0; o < code_dim_; ++o) projected[o] += sign[o] * v;
  }
  float largest = 0;
  for (int o = 0; o < code_dim_; ++o) largest = std::max(largest, std::fabs(projected[o]));
  std::vector<std::int8_t> code(static_cast<std::size_t>(code_dim_), 0);
  if (largest <= 0) return code;
  // Cosine similarity is scale-free, so each code uses its own full byte range.
  for (int o = 0; o < code_dim_; ++o)
    code[o] = static_cast<std::int8_t>(std::lround(projected[o] / largest * 127.0f));
  return code;
}

std::int32_t codeDot(const std::int8_t* a, const std::int8_t* b, std::size_t code_dim) {
  std::int32_t dot = 0;
  for (std::size_t i = 0; i < code_dim; ++i) dot += std::int32_t(a[i]) * b[i];
  return dot;
}

namespace {

#if defined(PLACEDB_CODE_DOTS_AVX2)
// Each byte widened to 16 bits and multiplied in pairs: exact for every int8 value, -128 too.
__attribute__((target("avx2"))) void codeDotsAvx2(const std::int8_t* query,
                                                  const std::int8_t* codes, std::size_t rows,
                                                  std::size_t code_dim, std::int32_t* out) {
  for (std::size_t r = 0; r < rows; ++r) {
    const std::int8_t* row = codes + r * code_dim;
    __m256i sum = _mm256_setzero_si256();
    for (std::size_t i = 0; i < code_dim; i += 16) {
      const __m256i q =
          _mm256_cvtepi8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(query + i)));
      const __m256i c =
          _mm256_cvtepi8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(row + i)));
      sum = _mm256_add_epi32(sum, _mm256_madd_epi16(q, c));
    }
    const __m128i half =
        _mm_add_epi32(_mm256_castsi256_si128(sum), _mm256_extracti128_si256(sum, 1));
    const __m128i pairs = _mm_add_epi32(half, _mm_shuffle_epi32(half, _MM_SHUFFLE(1, 0, 3, 2)));
    out[r] =
        _mm_cvtsi128_si32(_mm_add_epi32(pairs, _mm_shuffle_epi32(pairs, _MM_SHUFFLE(2, 3, 0, 1))));
  }
}

// sum + |q| . (c with q's sign), in eight 32-bit lanes.
__attribute__((target("avx2"))) inline __m256i addEncodedProducts(__m256i sum, __m256i magnitude,
                                                                  __m256i q, const std::int8_t* c) {
  const __m256i signed_c =
      _mm256_sign_epi8(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(c)), q);
  return _mm256_add_epi32(
      sum, _mm256_madd_epi16(_mm256_maddubs_epi16(magnitude, signed_c), _mm256_set1_epi16(1)));
}

// Four rows at a time, so each of the query's loads and signs serves four.
__attribute__((target("avx2"))) void encodedCodeDotsAvx2(const std::int8_t* query,
                                                         const std::int8_t* codes, std::size_t rows,
                                                         std::size_t code_dim, std::int32_t* out) {
  std::size_t r = 0;
  for (; r + 4 <= rows; r += 4) {
    const std::int8_t* row = codes + r * code_dim;
    __m256i s0 = _mm256_setzero_si256(), s1 = s0, s2 = s0, s3 = s0;
    for (std::size_t i = 0; i < code_dim; i += 32) {
      const __m256i q = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(query + i));
      const __m256i magnitude = _mm256_abs_epi8(q);
      s0 = addEncodedProducts(s0, magnitude, q, row + i);
      s1 = addEncodedProducts(s1, magnitude, q, row + code_dim + i);
      s2 = addEncodedProducts(s2, magnitude, q, row + 2 * code_dim + i);
      s3 = addEncodedProducts(s3, magnitude, q, row + 3 * code_dim + i);
    }
    // Lane sums: hadd twice leaves each row's two half-sums in the two 128-bit lanes.
    const __m256i pairs = _mm256_hadd_epi32(_mm256_hadd_epi32(s0, s1), _mm256_hadd_epi32(s2, s3));
    _mm_storeu_si128(
        reinterpret_cast<__m128i*>(out + r),
        _mm_add_epi32(_mm256_castsi256_si128(pairs), _mm256_extracti128_si256(pairs, 1)));
  }
  for (; r < rows; ++r) out[r] = codeDot(query, codes + r * code_dim, code_dim);
}
#endif

}  // namespace

bool withinEncodedRange(const std::int8_t* code, std::size_t code_dim) {
  return std::find(code, code + code_dim, std::numeric_limits<std::int8_t>::min()) ==
         code + code_dim;
}

void encodedCodeDots(const std::int8_t* query, const std::int8_t* codes, std::size_t rows,
                     std::size_t code_dim, std::int32_t* out) {
#if defined(PLACEDB_CODE_DOTS_AVX2)
  static const bool avx2 = simdAllows(SimdLevel::kAvx2);
  if (avx2 && code_dim % 32 == 0) {
    encodedCodeDotsAvx2(query, codes, rows, code_dim, out);
    return;
  }
#endif
  codeDots(query, codes, rows, code_dim, out);
}

void codeDots(const std::int8_t* query, const std::int8_t* codes, std::size_t rows,
              std::size_t code_dim, std::int32_t* out) {
#if defined(PLACEDB_CODE_DOTS_AVX2)
  static const bool avx2 = simdAllows(SimdLevel::kAvx2);
  if (avx2 && code_dim % 16 == 0) {
    codeDotsAvx2(query, codes, rows, code_dim, out);
    return;
  }
#endif
  for (std::size_t r = 0; r < rows; ++r) out[r] = codeDot(query, codes + r * code_dim, code_dim);
}

double codeSimilarity(const std::int8_t* a, const std::int8_t* b, int code_dim) {
  const auto n = static_cast<std::size_t>(code_dim);
  const std::int32_t na = codeDot(a, a, n), nb = codeDot(b, b, n);
  if (na == 0 || nb == 0) return 0.0;
  return double(codeDot(a, b, n)) / std::sqrt(double(na) * double(nb));
}

}  // namespace placedb
