#pragma once
// Synthetic correspondences for the epipolar fit and the decisions built on it: unrelated pairs,
// and a rigid scene seen from two poses.
#include <cmath>
#include <random>
#include <vector>

#include <opencv2/core.hpp>

namespace placedb::testing {

struct Pairs {
  std::vector<cv::Point2f> a, b;
};

inline Pairs noise(int n, cv::Size2f size, std::mt19937& rng) {
  std::uniform_real_distribution<float> x(0.f, size.width), y(0.f, size.height);
  Pairs p;
  for (int i = 0; i < n; ++i) {
    p.a.emplace_back(x(rng), y(rng));
    p.b.emplace_back(x(rng), y(rng));
  }
  return p;
}

// n points 4..12 m ahead seen by a pinhole camera (focal length 0.8 x width) before and after
// a sideways step and a small turn, with Gaussian keypoint noise; the first `outliers` pairs'
// candidate points are moved anywhere.
inline Pairs rigid(int n, int outliers, cv::Size2f size, float noise_px, std::mt19937& rng) {
  std::uniform_real_distribution<float> x(-2.f, 2.f), y(-1.5f, 1.5f), z(4.f, 12.f);
  std::uniform_real_distribution<float> u(0.f, size.width), v(0.f, size.height);
  std::normal_distribution<float> jitter(0.f, noise_px);
  const float f = 0.8f * size.width, cx = size.width / 2, cy = size.height / 2;
  const float turn = 0.05f, c = std::cos(turn), s = std::sin(turn);
  Pairs p;
  while (static_cast<int>(p.a.size()) < n) {
    const cv::Point3f q(x(rng), y(rng), z(rng));
    const cv::Point3f r(c * (q.x - 0.6f) + s * q.z, q.y, -s * (q.x - 0.6f) + c * q.z);
    const cv::Point2f pa(cx + f * q.x / q.z + jitter(rng), cy + f * q.y / q.z + jitter(rng));
    const cv::Point2f pb(cx + f * r.x / r.z + jitter(rng), cy + f * r.y / r.z + jitter(rng));
    if (pa.x < 0 || pa.y < 0 || pa.x > size.width || pa.y > size.height || pb.x < 0 || pb.y < 0 ||
        pb.x > size.width || pb.y > size.height)
      continue;
    p.a.push_back(pa);
    p.b.push_back(pb);
  }
  for (int i = 0; i < outliers && i < n; ++i) p.b[static_cast<std::size_t>(i)] = {u(rng), v(rng)};
  return p;
}

}  // namespace placedb::testing
