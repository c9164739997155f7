#include "features/surf_descriptor.h"

#include <array>
#include <cmath>

#include "features/parallel_for.h"

namespace placedb {
namespace {

constexpr float kPi = 3.14159265358979f;
constexpr int kOrientationRadius = 6;  // in units of the scale s
constexpr float kOrientationSigma = 2.0f;
constexpr int kOrientationBins = 72;        // 5 degrees each
constexpr int kOrientationWindowBins = 12;  // 60 degrees
constexpr int kDescriptorSamples = 20;      // per side of the 20s window
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

// Gaussian weight of descriptor sample (k, m), both 0..19, centred on the window.
const std::array<float, kDescriptorSamples * kDescriptorSamples>& descriptorWeights() {
  static const auto weights = [] {
    std::array<float, kDescriptorSamples * kDescriptorSamples> out{};
    const float inv_two_sigma_sq = 1.0f / (2.0f * kDescriptorSigma * kDescriptorSigma);
    for (int m = 0; m < kDescriptorSamples; ++m) {
      for (int k = 0; k < kDescriptorSamples; ++k) {
        const float u = k - (kDescriptorSamples - 1) / 2.0f;
        const float v = m - (kDescriptorSamples - 1) / 2.0f;
        out[m * kDescriptorSamples + k] = std::exp(-(u * u + v * v) * inv_two_sigma_sq);
      }
    }
    return out;
  }();
  return weights;
}

}  // namespace

float surfOrientation(const IntegralImage& integral, const cv::KeyPoint& keypoint) {
  const float s = blobScale(keypoint);
  const int half = std::max(1, static_cast<int>(std::lround(2.0f * s)));  // side 4s
  std::array<float, kOrientationBins> bin_x{}, bin_y{};
  for (const OrientationSample& sample : orientationSamples()) {
    float rx, ry;
    haarResponses(integral, nearestBoundary(keypoint.pt.x + sample.i * s),
                  nearestBoundary(keypoint.pt.y + sample.j * s), half, rx, ry);
    if (rx == 0.0f && ry == 0.0f) continue;
    const float angle = std::atan2(ry, rx) + kPi;  // [0, 2 pi]
    int bin = static_cast<int>(angle * (kOrientationBins / (2.0f * kPi)));
    if (bin >= kOrientationBins) bin -= kOrientationBins;
    bin_x[bin] += rx * sample.weight;
    bin_y[bin] += ry * sample.weight;
  }
  float best_x = 0, best_y = 0, best_norm = 0;
  for (int start = 0; start < kOrientationBins; ++start) {
    float sum_x = 0, sum_y = 0;
    for (int k = 0; k < kOrientationWindowBins; ++k) {
      const int bin = (start + k) % kOrientationBins;
      sum_x += bin_x[bin];
      sum_y += bin_y[bin];
    }
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
  const auto& weights = descriptorWeights();
  std::fill(out, out + kSurfDescriptorDim, 0.0f);
  for (int m = 0; m < kDescriptorSamples; ++m) {
    const float v = m - (kDescriptorSamples - 1) / 2.0f;
    for (int k = 0; k < kDescriptorSamples; ++k) {
      const float u = k - (kDescriptorSamples - 1) / 2.0f;
      // Sample (u, v) of the turned window, in image pixels.
      const float x = keypoint.pt.x + s * (u * cos_t - v * sin_t);
      const float y = keypoint.pt.y + s * (u * sin_t + v * cos_t);
      float rx, ry;
      haarResponses(integral, nearestBoundary(x), nearestBoundary(y), half, rx, ry);
      const float weight = weights[m * kDescriptorSamples + k];
      const float du = (rx * cos_t + ry * sin_t) * weight;
      const float dv = (-rx * sin_t + ry * cos_t) * weight;
      float* cell = out + 4 * ((m / kSamplesPerSubregion) * 4 + k / kSamplesPerSubregion);
      cell[0] += du;
      cell[1] += dv;
      cell[2] += std::abs(du);
      cell[3] += std::abs(dv);
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
