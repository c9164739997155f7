#include "features/surf_descriptor.h"

#include <algorithm>
#include <array>
#include <cmath>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#endif

#include "features/cpu_support.h"
#include "features/parallel_for.h"

namespace placedb {
namespace {

constexpr float kPi = 3.14159265358979f;
constexpr int kOrientationRadius = 6;  // in units of the scale s
constexpr float kOrientationSigma = 2.0f;
constexpr int kOrientationBins = 72;        // 5 degrees each
constexpr int kOrientationWindowBins = 12;  // 60 degrees
// Samples of the orientation disc, at most: those of its bounding square.
constexpr int kOrientationSamplesMax = (2 * kOrientationRadius + 1) * (2 * kOrientationRadius + 1);
constexpr int kDescriptorSamples = 20;  // per side of the 20s window
constexpr int kSamplesPerSubregion = 5;
constexpr float kDescriptorSigma = 3.3f;
constexpr int kKeypointsPerTask = 32;

// Filter scale s of a blob whose filter side is `size` (the 9-pixel filter has s = 1.2).
float blobScale(const cv::KeyPoint& keypoint) { return 1.2f * keypoint.size / 9.0f; }

// Integral-table coordinate of the pixel boundary nearest to pixel-centre coordinate p, so that
// a wavelet split there is centred on p.
int nearestBoundary(float p) { return static_cast<int>(std::floor(p + 1.0f)); }

// Haar wavelet responses of side 2 * half centred on table coordinate (a, b): right minus left
// half (rx) and bottom minus top half (ry). Corners are clamped to the image, so wavelets that
// leave the image only see what is inside.
void haarResponses(const IntegralImage& integral, int a, int b, int half, float& rx, float& ry) {
  int xs[3] = {a - half, a, a + half};
  int ys[3] = {b - half, b, b + half};
  if (xs[0] < 0 || ys[0] < 0 || xs[2] > integral.width() || ys[2] > integral.height()) {
    for (int i = 0; i < 3; ++i) {
      xs[i] = integral.clampX(xs[i]);
      ys[i] = integral.clampY(ys[i]);
    }
  }
  const std::uint32_t* table = integral.data();
  const int stride = integral.stride();
  auto t = [&](int i, int j) { return table[static_cast<std::size_t>(ys[j]) * stride + xs[i]]; };
  const std::uint32_t left = t(1, 2) - t(0, 2) - t(1, 0) + t(0, 0);
  const std::uint32_t right = t(2, 2) - t(1, 2) - t(2, 0) + t(1, 0);
  const std::uint32_t top = t(2, 1) - t(0, 1) - t(2, 0) + t(0, 0);
  const std::uint32_t bottom = t(2, 2) - t(0, 2) - t(2, 1) + t(0, 1);
  rx = static_cast<float>(static_cast<std::int32_t>(right - left));
  ry = static_cast<float>(static_cast<std::int32_t>(bottom - top));
}

// haarResponses() of `count` centres (a[i], b[i]), all of side 2 * half.
void haarResponsesOf(const IntegralImage& integral, const int* a, const int* b, int count, int half,
                     float* rx, float* ry) {
  for (int i = 0; i < count; ++i) haarResponses(integral, a[i], b[i], half, rx[i], ry[i]);
}

#if defined(__GNUC__) && defined(__x86_64__)
#define PLACEDB_HAAR_AVX2 1
__attribute__((target("avx2"))) inline __m256i clampTo(__m256i v, __m256i high) {
  return _mm256_min_epi32(_mm256_max_epi32(v, _mm256_setzero_si256()), high);
}

// The same, eight centres at a time with AVX2 gathers: the same integer sums, so the same
// responses. Clamping a corner that lies inside the image leaves it as it is, so every corner
// is clamped here, where haarResponses() clamps only boxes that leave the image.
__attribute__((target("avx2"))) void haarResponsesAvx2(const IntegralImage& integral, const int* a,
                                                       const int* b, int count, int half, float* rx,
                                                       float* ry) {
  const int* table = reinterpret_cast<const int*>(integral.data());
  const __m256i halves = _mm256_set1_epi32(half);
  const __m256i width = _mm256_set1_epi32(integral.width());
  const __m256i height = _mm256_set1_epi32(integral.height());
  const __m256i stride = _mm256_set1_epi32(integral.stride());
  int i = 0;
  for (; i + 8 <= count; i += 8) {
    const __m256i ca = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(a + i));
    const __m256i cb = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(b + i));
    const __m256i x[3] = {clampTo(_mm256_sub_epi32(ca, halves), width), clampTo(ca, width),
                          clampTo(_mm256_add_epi32(ca, halves), width)};
    __m256i row[3] = {clampTo(_mm256_sub_epi32(cb, halves), height), clampTo(cb, height),
                      clampTo(_mm256_add_epi32(cb, halves), height)};
    for (__m256i& r : row) r = _mm256_mullo_epi32(r, stride);
#define PLACEDB_HAAR_CORNER(xi, yj) \
  _mm256_i32gather_epi32(table, _mm256_add_epi32(row[yj], x[xi]), 4)
    const __m256i t00 = PLACEDB_HAAR_CORNER(0, 0), t10 = PLACEDB_HAAR_CORNER(1, 0);
    const __m256i t20 = PLACEDB_HAAR_CORNER(2, 0), t01 = PLACEDB_HAAR_CORNER(0, 1);
    const __m256i t21 = PLACEDB_HAAR_CORNER(2, 1), t02 = PLACEDB_HAAR_CORNER(0, 2);
    const __m256i t12 = PLACEDB_HAAR_CORNER(1, 2), t22 = PLACEDB_HAAR_CORNER(2, 2);
#undef PLACEDB_HAAR_CORNER
    const __m256i left = _mm256_add_epi32(_mm256_sub_epi32(_mm256_sub_epi32(t12, t02), t10), t00);
    const __m256i right = _mm256_add_epi32(_mm256_sub_epi32(_mm256_sub_epi32(t22, t12), t20), t10);
    const __m256i top = _mm256_add_epi32(_mm256_sub_epi32(_mm256_sub_epi32(t21, t01), t20), t00);
    const __m256i bottom = _mm256_add_epi32(_mm256_sub_epi32(_mm256_sub_epi32(t22, t02), t21), t01);
    _mm256_storeu_ps(rx + i, _mm256_cvtepi32_ps(_mm256_sub_epi32(right, left)));
    _mm256_storeu_ps(ry + i, _mm256_cvtepi32_ps(_mm256_sub_epi32(bottom, top)));
  }
  haarResponsesOf(integral, a + i, b + i, count - i, half, rx + i, ry + i);
}
#endif

struct OrientationSample {
  int i, j;
  float weight;
};

const std::vector<OrientationSample>& orientationSamples() {
  static const std::vector<OrientationSample> samples = [] {
    std::vector<OrientationSample> out;
    const float inv_two_sigma_sq = 1.0f / (2.0f * kOrientationSigma * kOrientationSigma);
    for (int j = -kOrientationRadius; j <= kOrientationRadius; ++j) {
      for (int i = -kOrientationRadius; i <= kOrientationRadius; ++i) {
        const int r2 = i * i + j * j;
        if (r2 < kOrientationRadius * kOrientationRadius) {
          out.push_back({i, j, std::exp(-static_cast<float>(r2) * inv_two_sigma_sq)});
        }
      }
    }
    return out;
  }();
  return samples;
}

// The descriptor's samples, in the order (row m, column j of a sub-region, sub-region column q)
// of the window's column k = 5 q + j: one row's samples of the four sub-regions side by side, so
// that each sub-region's sums take its samples in the order of rows then columns while the four
// are summed together.
constexpr int kDescriptorSampleCount = kDescriptorSamples * kDescriptorSamples;
struct DescriptorSamples {
  // Offsets (u, v) from the window's centre, in units of s, and Gaussian weights.
  std::array<float, kDescriptorSampleCount> u{}, v{}, weight{};
};

const DescriptorSamples& descriptorSamples() {
  static const DescriptorSamples samples = [] {
    DescriptorSamples out;
    const float inv_two_sigma_sq = 1.0f / (2.0f * kDescriptorSigma * kDescriptorSigma);
    int p = 0;
    for (int m = 0; m < kDescriptorSamples; ++m) {
      for (int j = 0; j < kSamplesPerSubregion; ++j) {
        for (int q = 0; q < 4; ++q, ++p) {
          const int k = q * kSamplesPerSubregion + j;
          const float u = k - (kDescriptorSamples - 1) / 2.0f;
          const float v = m - (kDescriptorSamples - 1) / 2.0f;
          out.u[p] = u;
          out.v[p] = v;
          out.weight[p] = std::exp(-(u * u + v * v) * inv_two_sigma_sq);
        }
      }
    }
    return out;
  }();
  return samples;
}

// Sample p's table coordinates: nearestBoundary() of (x0 + s (u cos - v sin), y0 + s (u sin +
// v cos)).
void descriptorCentres(const DescriptorSamples& samples, float x0, float y0, float s, float cos_t,
                       float sin_t, int* a, int* b) {
  for (int p = 0; p < kDescriptorSampleCount; ++p) {
    const float u = samples.u[p], v = samples.v[p];
    a[p] = nearestBoundary(x0 + s * (u * cos_t - v * sin_t));
    b[p] = nearestBoundary(y0 + s * (u * sin_t + v * cos_t));
  }
}

#if defined(__GNUC__) && defined(__x86_64__)
#define PLACEDB_DESCRIPTOR_CENTRES_AVX2 1
// The same, eight samples at a time: the same float operations in the same order (AVX2 alone has
// no fused multiply-add to round differently), and floor as nearestBoundary() takes it.
__attribute__((target("avx2"))) void descriptorCentresAvx2(const DescriptorSamples& samples,
                                                           float x0, float y0, float s, float cos_t,
                                                           float sin_t, int* a, int* b) {
  const __m256 vx0 = _mm256_set1_ps(x0), vy0 = _mm256_set1_ps(y0), vs = _mm256_set1_ps(s);
  const __m256 vc = _mm256_set1_ps(cos_t), vsn = _mm256_set1_ps(sin_t);
  const __m256 one = _mm256_set1_ps(1.0f);
  static_assert(kDescriptorSampleCount % 8 == 0, "whole vectors of samples");
  for (int p = 0; p < kDescriptorSampleCount; p += 8) {
    const __m256 u = _mm256_loadu_ps(samples.u.data() + p);
    const __m256 v = _mm256_loadu_ps(samples.v.data() + p);
    const __m256 x = _mm256_add_ps(
        vx0, _mm256_mul_ps(vs, _mm256_sub_ps(_mm256_mul_ps(u, vc), _mm256_mul_ps(v, vsn))));
    const __m256 y = _mm256_add_ps(
        vy0, _mm256_mul_ps(vs, _mm256_add_ps(_mm256_mul_ps(u, vsn), _mm256_mul_ps(v, vc))));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(a + p),
                        _mm256_cvttps_epi32(_mm256_floor_ps(_mm256_add_ps(x, one))));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(b + p),
                        _mm256_cvttps_epi32(_mm256_floor_ps(_mm256_add_ps(y, one))));
  }
}
#endif

// The orientation bin of a response, as atan2f puts it.
int exactOrientationBin(float rx, float ry) {
  const float angle = std::atan2(ry, rx) + kPi;  // [0, 2 pi]
  int bin = static_cast<int>(angle * (kOrientationBins / (2.0f * kPi)));
  if (bin >= kOrientationBins) bin -= kOrientationBins;
  return bin;
}

// orientationBin() is exactOrientationBin() without atan2f (a sixth of SURF's instructions on
// lip6_outdoor) for all but the responses within kBinEdgeMargin of a bin edge. In units of bins,
// atan2f's result is within a few ulp of the true angle, and the float sum and product add half
// an ulp each: under 2e-5 of a bin in all. The series below is within 2e-8 radians (2.3e-7
// bins) of the true angle, its double arithmetic far closer. A response further than
// kBinEdgeMargin from an edge therefore falls in the same bin either way.
constexpr double kBinEdgeMargin = 1e-4;

constexpr double kTanPiOver8 = 0.41421356237309503;
constexpr double kPiD = 3.14159265358979323846;
const double kToBins = static_cast<double>(kOrientationBins / (2.0f * kPi));
// atan(u) = u (1 - u^2 / 3 + u^4 / 5 - ... - u^14 / 15) for |u| <= tan(pi / 8): the first term
// left out, |u|^17 / 17, is under 1.8e-8. Highest power first, for Horner's rule.
constexpr double kAtanSeries[] = {-1.0 / 15, 1.0 / 13, -1.0 / 11, 1.0 / 9,
                                  -1.0 / 7,  1.0 / 5,  -1.0 / 3,  1.0};

// Where a response's angle falls, in bins from the edge of bin 0 (atan2 + pi, scaled), for
// orientationBin(). A response (0, 0) gives NaN.
double orientationPosition(float rx, float ry) {
  const double x = rx, y = ry;
  const double ax = std::abs(x), ay = std::abs(y);
  // atan of t = min / max in [0, 1]; above tan(pi / 8), through atan(t) = pi / 4 + atan(u).
  const double t = std::min(ax, ay) / std::max(ax, ay);
  const bool folded = t > kTanPiOver8;
  const double u = folded ? (t - 1) / (t + 1) : t;
  double series = 0;
  for (double c : kAtanSeries) series = c + u * u * series;
  double a = (folded ? kPiD / 4 : 0.0) + u * series;
  if (ay > ax) a = kPiD / 2 - a;
  if (x < 0) a = kPiD - a;
  if (y < 0) a = -a;
  return (a + static_cast<double>(kPi)) * kToBins;
}

#if defined(__GNUC__) && defined(__x86_64__)
#define PLACEDB_ORIENTATION_AVX2 1
// orientationPosition() four responses at a time, for the first count - count % 4 of them: the
// same double operations as the two-at-a-time loop below, so the same bits.
__attribute__((target("avx2"))) inline __m256d whereElse(__m256d mask, __m256d yes, __m256d no) {
  return _mm256_or_pd(_mm256_and_pd(mask, yes), _mm256_andnot_pd(mask, no));
}

__attribute__((target("avx2"))) int orientationPositionsAvx2(const float* rx, const float* ry,
                                                             int count, double* positions) {
  const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0), sign = _mm256_set1_pd(-0.0);
  int i = 0;
  for (; i + 4 <= count; i += 4) {
    const __m256d x = _mm256_cvtps_pd(_mm_loadu_ps(rx + i));
    const __m256d y = _mm256_cvtps_pd(_mm_loadu_ps(ry + i));
    const __m256d ax = _mm256_andnot_pd(sign, x), ay = _mm256_andnot_pd(sign, y);
    const __m256d t = _mm256_div_pd(_mm256_min_pd(ax, ay), _mm256_max_pd(ax, ay));
    const __m256d folded = _mm256_cmp_pd(t, _mm256_set1_pd(kTanPiOver8), _CMP_GT_OS);
    const __m256d u =
        whereElse(folded, _mm256_div_pd(_mm256_sub_pd(t, one), _mm256_add_pd(t, one)), t);
    const __m256d z = _mm256_mul_pd(u, u);
    __m256d series = zero;
    for (double c : kAtanSeries)
      series = _mm256_add_pd(_mm256_set1_pd(c), _mm256_mul_pd(z, series));
    __m256d a =
        _mm256_add_pd(_mm256_and_pd(folded, _mm256_set1_pd(kPiD / 4)), _mm256_mul_pd(u, series));
    a = whereElse(_mm256_cmp_pd(ay, ax, _CMP_GT_OS), _mm256_sub_pd(_mm256_set1_pd(kPiD / 2), a), a);
    a = whereElse(_mm256_cmp_pd(x, zero, _CMP_LT_OS), _mm256_sub_pd(_mm256_set1_pd(kPiD), a), a);
    a = _mm256_xor_pd(a, _mm256_and_pd(_mm256_cmp_pd(y, zero, _CMP_LT_OS), sign));
    const __m256d shifted = _mm256_add_pd(a, _mm256_set1_pd(static_cast<double>(kPi)));
    _mm256_storeu_pd(positions + i, _mm256_mul_pd(shifted, _mm256_set1_pd(kToBins)));
  }
  return i;
}
#endif

void orientationPositions(const float* rx, const float* ry, int count, double* positions) {
  int i = 0;
#if defined(PLACEDB_ORIENTATION_AVX2)
  static const bool avx2 = simdAllows(SimdLevel::kAvx2);
  if (avx2) i = orientationPositionsAvx2(rx, ry, count, positions);
#endif
#if defined(__SSE2__)
  // orientationPosition() two responses at a time, its branches as masks (the compiler keeps
  // them branches and takes one response at a time).
  const auto select = [](__m128d mask, __m128d yes, __m128d no) {
    return _mm_or_pd(_mm_and_pd(mask, yes), _mm_andnot_pd(mask, no));
  };
  const __m128d zero = _mm_setzero_pd(), one = _mm_set1_pd(1.0), sign = _mm_set1_pd(-0.0);
  for (; i + 2 <= count; i += 2) {
    const __m128d x = _mm_set_pd(rx[i + 1], rx[i]), y = _mm_set_pd(ry[i + 1], ry[i]);
    const __m128d ax = _mm_andnot_pd(sign, x), ay = _mm_andnot_pd(sign, y);
    const __m128d t = _mm_div_pd(_mm_min_pd(ax, ay), _mm_max_pd(ax, ay));
    const __m128d folded = _mm_cmpgt_pd(t, _mm_set1_pd(kTanPiOver8));
    const __m128d u = select(folded, _mm_div_pd(_mm_sub_pd(t, one), _mm_add_pd(t, one)), t);
    const __m128d z = _mm_mul_pd(u, u);
    __m128d series = zero;
    for (double c : kAtanSeries) series = _mm_add_pd(_mm_set1_pd(c), _mm_mul_pd(z, series));
    __m128d a = _mm_add_pd(_mm_and_pd(folded, _mm_set1_pd(kPiD / 4)), _mm_mul_pd(u, series));
    a = select(_mm_cmpgt_pd(ay, ax), _mm_sub_pd(_mm_set1_pd(kPiD / 2), a), a);
    a = select(_mm_cmplt_pd(x, zero), _mm_sub_pd(_mm_set1_pd(kPiD), a), a);
    a = _mm_xor_pd(a, _mm_and_pd(_mm_cmplt_pd(y, zero), sign));
    const __m128d shifted = _mm_add_pd(a, _mm_set1_pd(static_cast<double>(kPi)));
    _mm_storeu_pd(positions + i, _mm_mul_pd(shifted, _mm_set1_pd(kToBins)));
  }
#endif
  for (; i < count; ++i) positions[i] = orientationPosition(rx[i], ry[i]);
}

int orientationBin(double position, float rx, float ry) {
  // position > 0: the float pi is above pi.
  const int bin = static_cast<int>(position);
  const double within = position - bin;
  if (within <= kBinEdgeMargin || within >= 1 - kBinEdgeMargin) return exactOrientationBin(rx, ry);
  return bin >= kOrientationBins ? bin - kOrientationBins : bin;
}

}  // namespace

void surfHaarResponses(const IntegralImage& integral, const int* a, const int* b, int count,
                       int half, float* rx, float* ry) {
#if defined(PLACEDB_HAAR_AVX2)
  static const bool avx2 = simdAllows(SimdLevel::kAvx2);
  if (avx2) {
    haarResponsesAvx2(integral, a, b, count, half, rx, ry);
    return;
  }
#endif
  haarResponsesOf(integral, a, b, count, half, rx, ry);
}

void surfOrientationBins(const float* rx, const float* ry, int count, int* bins) {
  constexpr int kBlock = 64;
  double positions[kBlock];
  for (int first = 0; first < count; first += kBlock) {
    const int n = std::min(kBlock, count - first);
    orientationPositions(rx + first, ry + first, n, positions);
    for (int i = 0; i < n; ++i) {
      const float x = rx[first + i], y = ry[first + i];
      bins[first + i] = x == 0.0f && y == 0.0f ? -1 : orientationBin(positions[i], x, y);
    }
  }
}

float surfOrientation(const IntegralImage& integral, const cv::KeyPoint& keypoint) {
  const float s = blobScale(keypoint);
  const int half = std::max(1, static_cast<int>(std::lround(2.0f * s)));  // side 4s
  const std::vector<OrientationSample>& samples = orientationSamples();
  const int count = static_cast<int>(samples.size());
  std::array<int, kOrientationSamplesMax> a, b;
  for (int i = 0; i < count; ++i) {
    const OrientationSample& sample = samples[static_cast<std::size_t>(i)];
    a[i] = nearestBoundary(keypoint.pt.x + sample.i * s);
    b[i] = nearestBoundary(keypoint.pt.y + sample.j * s);
  }
  std::array<float, kOrientationSamplesMax> rx, ry;
  surfHaarResponses(integral, a.data(), b.data(), count, half, rx.data(), ry.data());
  std::array<int, kOrientationSamplesMax> bins;
  surfOrientationBins(rx.data(), ry.data(), count, bins.data());
  // The bins and their window sums, each in the order of the straightforward loops. The bins
  // repeat past the last so that a window needs no wrap-around.
  std::array<float, kOrientationBins + kOrientationWindowBins> bin_x{}, bin_y{};
  for (int i = 0; i < count; ++i) {
    const int bin = bins[i];
    if (bin < 0) continue;
    const float weight = samples[static_cast<std::size_t>(i)].weight;
    bin_x[bin] += rx[i] * weight;
    bin_y[bin] += ry[i] * weight;
  }
  for (int k = 0; k < kOrientationWindowBins; ++k) {
    bin_x[kOrientationBins + k] = bin_x[k];
    bin_y[kOrientationBins + k] = bin_y[k];
  }
  // Every window's sum from 0 in the same order, the windows side by side.
  std::array<float, kOrientationBins> sums_x{}, sums_y{};
  for (int k = 0; k < kOrientationWindowBins; ++k) {
    for (int start = 0; start < kOrientationBins; ++start) {
      sums_x[start] += bin_x[start + k];
      sums_y[start] += bin_y[start + k];
    }
  }
  float best_x = 0, best_y = 0, best_norm = 0;
  for (int start = 0; start < kOrientationBins; ++start) {
    const float sum_x = sums_x[start], sum_y = sums_y[start];
    const float norm = sum_x * sum_x + sum_y * sum_y;
    if (norm > best_norm) {
      best_norm = norm;
      best_x = sum_x;
      best_y = sum_y;
    }
  }
  if (best_norm == 0.0f) return 0.0f;
  float degrees = std::atan2(best_y, best_x) * (180.0f / kPi);
  if (degrees < 0) degrees += 360.0f;
  return degrees >= 360.0f ? 0.0f : degrees;
}

void surfDescriptor(const IntegralImage& integral, const cv::KeyPoint& keypoint, float* out) {
  const float s = blobScale(keypoint);
  const int half = std::max(1, static_cast<int>(std::lround(s)));  // side 2s
  const float theta = keypoint.angle < 0 ? 0.0f : keypoint.angle * (kPi / 180.0f);
  const float cos_t = std::cos(theta), sin_t = std::sin(theta);
  const DescriptorSamples& samples = descriptorSamples();
  // The turned window's samples, in image pixels.
  std::array<int, kDescriptorSampleCount> a, b;
#if defined(PLACEDB_DESCRIPTOR_CENTRES_AVX2)
  static const bool avx2 = simdAllows(SimdLevel::kAvx2);
  if (avx2) {
    descriptorCentresAvx2(samples, keypoint.pt.x, keypoint.pt.y, s, cos_t, sin_t, a.data(),
                          b.data());
  } else
#endif
  {
    descriptorCentres(samples, keypoint.pt.x, keypoint.pt.y, s, cos_t, sin_t, a.data(), b.data());
  }
  std::array<float, kDescriptorSampleCount> rx, ry, du, dv;
  surfHaarResponses(integral, a.data(), b.data(), kDescriptorSampleCount, half, rx.data(),
                    ry.data());
  for (int p = 0; p < kDescriptorSampleCount; ++p) {
    du[p] = (rx[p] * cos_t + ry[p] * sin_t) * samples.weight[p];
    dv[p] = (-rx[p] * sin_t + ry[p] * cos_t) * samples.weight[p];
  }
  // Sums per sub-region: [band of rows][quantity][sub-region column].
  float sums[4][4][4] = {};
  for (int m = 0, p = 0; m < kDescriptorSamples; ++m) {
    float(&band)[4][4] = sums[m / kSamplesPerSubregion];
    for (int j = 0; j < kSamplesPerSubregion; ++j, p += 4) {
      for (int q = 0; q < 4; ++q) {
        band[0][q] += du[p + q];
        band[1][q] += dv[p + q];
        band[2][q] += std::abs(du[p + q]);
        band[3][q] += std::abs(dv[p + q]);
      }
    }
  }
  for (int row = 0; row < 4; ++row) {
    for (int q = 0; q < 4; ++q) {
      for (int quantity = 0; quantity < 4; ++quantity)
        out[4 * (row * 4 + q) + quantity] = sums[row][quantity][q];
    }
  }
  double norm_sq = 0;
  for (int i = 0; i < kSurfDescriptorDim; ++i) norm_sq += static_cast<double>(out[i]) * out[i];
  if (norm_sq > 0) {
    const auto inv_norm = static_cast<float>(1.0 / std::sqrt(norm_sq));
    for (int i = 0; i < kSurfDescriptorDim; ++i) out[i] *= inv_norm;
  }
}

void describeSurfKeypoints(const IntegralImage& integral, std::vector<cv::KeyPoint>& keypoints,
                           bool upright, int threads, cv::Mat& descriptors) {
  const int count = static_cast<int>(keypoints.size());
  descriptors.create(count, kSurfDescriptorDim, CV_32F);
  const int tasks = (count + kKeypointsPerTask - 1) / kKeypointsPerTask;
  parallelFor(tasks, threads, [&](int t) {
    const int end = std::min(count, (t + 1) * kKeypointsPerTask);
    for (int i = t * kKeypointsPerTask; i < end; ++i) {
      cv::KeyPoint& keypoint = keypoints[i];
      keypoint.angle = upright ? -1.0f : surfOrientation(integral, keypoint);
      surfDescriptor(integral, keypoint, descriptors.ptr<float>(i));
    }
  });
}

}  // namespace placedb
