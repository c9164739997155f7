// SURF-64 contract: the same bits every time, unit descriptors, ranking and limits honoured,
// upright mode, and thread count not changing the result.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "features/feature_extractor.h"
#include "features/image_conversion.h"
#include "features/integral_image.h"
#include "features/surf_descriptor.h"
#include "test_paths.h"

namespace placedb {
namespace {

// Blobs of many sizes on a ramp.
cv::Mat blobsOnARamp() {
  cv::Mat image(240, 320, CV_8UC1);
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x) image.at<uchar>(y, x) = static_cast<uchar>(60 + x / 4);
  cv::RNG rng(3);
  for (int i = 0; i < 120; ++i) {
    cv::circle(image, {rng.uniform(0, image.cols), rng.uniform(0, image.rows)}, rng.uniform(2, 14),
               cv::Scalar(rng.uniform(0, 256)), cv::FILLED, cv::LINE_AA);
  }
  return image;
}

// A real frame when the data sets are there, else blobsOnARamp() (the contract does not depend
// on the scene, so these tests never skip).
cv::Mat testImage() {
  const auto dir = testing::dataset("lip6_outdoor");
  if (!dir.empty()) {
    return loadGreyImage((dir / "images/outdoor_kennedylong_000200.png").string());
  }
  return blobsOnARamp();
}

Features surfOf(const cv::Mat& image, FeatureOptions options = FeatureOptions()) {
  options.extractor = "surf";
  return makeFeatureExtractor(options)->extract(image);
}

bool bitIdentical(const Features& a, const Features& b) {
  if (a.size() != b.size() || a.descriptors.size() != b.descriptors.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Keypoint& p = a.keypoints[i];
    const Keypoint& q = b.keypoints[i];
    if (std::memcmp(&p.x, &q.x, sizeof(float)) || std::memcmp(&p.y, &q.y, sizeof(float)) ||
        std::memcmp(&p.size, &q.size, sizeof(float)) ||
        std::memcmp(&p.angle, &q.angle, sizeof(float)) ||
        std::memcmp(&p.response, &q.response, sizeof(float)) || p.octave != q.octave) {
      return false;
    }
  }
  const std::size_t bytes = a.descriptors.total() * a.descriptors.elemSize();
  return bytes == 0 || std::memcmp(a.descriptors.data, b.descriptors.data, bytes) == 0;
}

TEST(SurfBehaviour, SameImageGivesBitIdenticalResult) {
  const cv::Mat image = testImage();
  const Features first = surfOf(image);
  ASSERT_GT(first.size(), 50u) << "too few features for the test to mean anything";
  EXPECT_TRUE(bitIdentical(first, surfOf(image.clone())));
}

TEST(SurfBehaviour, ThreadCountDoesNotChangeTheBits) {
  const cv::Mat image = testImage();
  FeatureOptions two;
  two.threads = 2;
  EXPECT_TRUE(bitIdentical(surfOf(image), surfOf(image, two)));
}

TEST(SurfBehaviour, ShapeAndDescriptorsAreUnitLength) {
  const Features features = surfOf(testImage());
  EXPECT_EQ(features.extractor, "surf");
  EXPECT_EQ(features.dim, 64);
  EXPECT_EQ(features.type, DescriptorType::kFloat32);
  ASSERT_EQ(features.descriptors.rows, static_cast<int>(features.size()));
  ASSERT_EQ(features.descriptors.cols, 64);
  ASSERT_EQ(features.descriptors.type(), CV_32F);
  EXPECT_TRUE(features.descriptors.isContinuous());
  for (int i = 0; i < features.descriptors.rows; ++i) {
    EXPECT_NEAR(cv::norm(features.descriptors.row(i)), 1.0, 1e-4) << "descriptor " << i;
  }
}

TEST(SurfBehaviour, StrongestFirstAndResponsesAboveThreshold) {
  FeatureOptions options;
  const Features features = surfOf(testImage(), options);
  for (std::size_t i = 0; i < features.size(); ++i) {
    EXPECT_GE(features.keypoints[i].response, options.hessian_threshold);
    EXPECT_GE(features.keypoints[i].angle, 0.0f);
    EXPECT_LT(features.keypoints[i].angle, 360.0f);
    if (i > 0) {
      EXPECT_GE(features.keypoints[i - 1].response, features.keypoints[i].response);
    }
  }
}

TEST(SurfBehaviour, MaxFeaturesKeepsTheStrongest) {
  const cv::Mat image = testImage();
  const Features all = surfOf(image);
  ASSERT_GT(all.size(), 40u);
  FeatureOptions capped;
  capped.max_features = 25;
  const Features top = surfOf(image, capped);
  ASSERT_EQ(top.size(), 25u);
  for (std::size_t i = 0; i < top.size(); ++i) {
    EXPECT_EQ(top.keypoints[i].x, all.keypoints[i].x);
    EXPECT_EQ(top.keypoints[i].response, all.keypoints[i].response);
    EXPECT_EQ(cv::norm(top.descriptors.row(i), all.descriptors.row(i), cv::NORM_INF), 0);
  }
}

TEST(SurfBehaviour, MinResponseDropsWeakerFeatures) {
  const cv::Mat image = testImage();
  const Features all = surfOf(image);
  ASSERT_GT(all.size(), 40u);
  FeatureOptions options;
  options.min_response = all.keypoints[all.size() / 2].response;
  const Features strong = surfOf(image, options);
  std::size_t expected = 0;
  for (const Keypoint& k : all.keypoints) expected += k.response >= options.min_response;
  EXPECT_EQ(strong.size(), expected);
  EXPECT_LT(strong.size(), all.size());
  for (const Keypoint& k : strong.keypoints) EXPECT_GE(k.response, options.min_response);
}

TEST(SurfBehaviour, UprightGivesAngleMinusOne) {
  FeatureOptions options;
  options.upright = true;
  const Features features = surfOf(testImage(), options);
  ASSERT_GT(features.size(), 0u);
  for (const Keypoint& k : features.keypoints) EXPECT_EQ(k.angle, -1.0f);
  for (int i = 0; i < features.descriptors.rows; ++i) {
    EXPECT_NEAR(cv::norm(features.descriptors.row(i)), 1.0, 1e-4);
  }
}

TEST(SurfBehaviour, FeatureTargetSearchesAStarvedImageAgainAtTwiceItsSize) {
  cv::Mat small;
  cv::resize(testImage(), small, cv::Size(), 0.375, 0.375, cv::INTER_AREA);
  FeatureOptions options;
  options.feature_target = 0;
  const Features native = surfOf(small, options);
  options.feature_target = 2 * static_cast<int>(native.size()) + 20;
  const Features finer = surfOf(small, options);
  EXPECT_GE(finer.size(), 2 * native.size());
  EXPECT_LE(finer.size(), static_cast<std::size_t>(options.feature_target));
  // In the given image's own pixels, so that the check and a pose see that image.
  for (const Keypoint& k : finer.keypoints) {
    EXPECT_GE(k.x, 0.f);
    EXPECT_LT(k.x, static_cast<float>(small.cols));
    EXPECT_GE(k.y, 0.f);
    EXPECT_LT(k.y, static_cast<float>(small.rows));
  }
  EXPECT_TRUE(bitIdentical(finer, surfOf(small, options)));
}

TEST(SurfBehaviour, FeatureTargetSearchesAgainAnImageWithFewerThanIt) {
  // More than half the target: the old rule (feature_retry 0.5) left such an image alone, and a
  // 160x120 camera with ~55 features a frame never reached the finer search.
  cv::Mat small;
  cv::resize(testImage(), small, cv::Size(), 0.375, 0.375, cv::INTER_AREA);
  FeatureOptions options;
  options.feature_target = 0;
  const Features native = surfOf(small, options);
  ASSERT_GT(native.size(), 4u);
  options.feature_target = static_cast<int>(native.size()) * 3 / 2;
  const Features finer = surfOf(small, options);
  EXPECT_FALSE(bitIdentical(native, finer));
  EXPECT_GE(finer.size(), native.size());
  EXPECT_LE(finer.size(), static_cast<std::size_t>(options.feature_target));
  EXPECT_EQ(finer.image_size, small.size());
  options.feature_retry = 0.5;
  EXPECT_TRUE(bitIdentical(native, surfOf(small, options)));
}

TEST(SurfBehaviour, FeatureTargetLeavesAnImageWithMoreThanItAlone) {
  const cv::Mat image = testImage();
  FeatureOptions options;
  options.feature_target = 0;
  const Features plain = surfOf(image, options);
  options.feature_target = static_cast<int>(plain.size()) - 1;
  EXPECT_TRUE(bitIdentical(plain, surfOf(image, options)));
  options.feature_retry = 0.5;
  options.feature_target = 2 * static_cast<int>(plain.size()) - 1;  // more than half of it
  EXPECT_TRUE(bitIdentical(plain, surfOf(image, options)));
}

// The orientation bin as SURF defines it here: atan2f, float arithmetic as written.
int atan2fBin(float rx, float ry) {
  const float pi = 3.14159265358979f;
  const float angle = std::atan2(ry, rx) + pi;
  const int bin = static_cast<int>(angle * (72 / (2.0f * pi)));
  return bin >= 72 ? bin - 72 : bin;
}

TEST(SurfBehaviour, OrientationBinsAreAtan2fsOnEveryResponse) {
  // Haar responses are integers: every one up to 300 either way (the axes, the diagonals and
  // the bin edges among them), then large random ones.
  std::vector<float> rx, ry;
  for (int x = -300; x <= 300; ++x) {
    for (int y = -300; y <= 300; ++y) {
      rx.push_back(static_cast<float>(x));
      ry.push_back(static_cast<float>(y));
    }
  }
  cv::RNG rng(9);
  for (int i = 0; i < 200000; ++i) {
    rx.push_back(static_cast<float>(rng.uniform(-5000000, 5000000)));
    ry.push_back(static_cast<float>(rng.uniform(-5000000, 5000000)));
  }
  std::vector<int> bins(rx.size());
  surfOrientationBins(rx.data(), ry.data(), static_cast<int>(rx.size()), bins.data());
  int wrong = 0;
  for (std::size_t i = 0; i < rx.size(); ++i) {
    const int expected = rx[i] == 0.0f && ry[i] == 0.0f ? -1 : atan2fBin(rx[i], ry[i]);
    if (bins[i] != expected && ++wrong <= 5)
      ADD_FAILURE() << "(" << rx[i] << ", " << ry[i] << "): bin " << bins[i] << ", atan2f "
                    << expected;
  }
  EXPECT_EQ(wrong, 0);
}

TEST(SurfBehaviour, HaarResponsesAreTheClampedBoxSumsEverywhere) {
  // Centres inside, on and beyond every border, at small and large sides, in runs long enough
  // for the eight-wide path and with tails for the one-at-a-time path.
  const IntegralImage integral(testImage());
  const int w = integral.width(), h = integral.height();
  cv::RNG rng(11);
  for (int half : {1, 2, 3, 7, 20}) {
    std::vector<int> a, b;
    for (int i = 0; i < 1003; ++i) {
      a.push_back(rng.uniform(-half - 3, w + half + 4));
      b.push_back(rng.uniform(-half - 3, h + half + 4));
    }
    std::vector<float> rx(a.size()), ry(a.size());
    surfHaarResponses(integral, a.data(), b.data(), static_cast<int>(a.size()), half, rx.data(),
                      ry.data());
    int wrong = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      const int x = a[i], y = b[i];
      const int right = integral.boxSumClamped(x, y - half, x + half, y + half);
      const int left = integral.boxSumClamped(x - half, y - half, x, y + half);
      const int bottom = integral.boxSumClamped(x - half, y, x + half, y + half);
      const int top = integral.boxSumClamped(x - half, y - half, x + half, y);
      if ((rx[i] != static_cast<float>(right - left) ||
           ry[i] != static_cast<float>(bottom - top)) &&
          ++wrong <= 5) {
        ADD_FAILURE() << "half " << half << " at (" << x << ", " << y << "): (" << rx[i] << ", "
                      << ry[i] << "), boxes give (" << right - left << ", " << bottom - top << ")";
      }
    }
    EXPECT_EQ(wrong, 0) << "half " << half;
  }
}

TEST(SurfBehaviour, AnImageOfAnotherSizeInBetweenChangesNoBit) {
  // The detector keeps its buffers from one image to the next.
  const cv::Mat image = testImage();
  const Features first = surfOf(image);
  cv::Mat small, large;
  cv::resize(image, small, cv::Size(), 0.5, 0.5, cv::INTER_AREA);
  cv::resize(image, large, cv::Size(), 1.5, 1.5, cv::INTER_LINEAR);
  ASSERT_GT(surfOf(small).size(), 0u);
  EXPECT_TRUE(bitIdentical(first, surfOf(image)));
  ASSERT_GT(surfOf(large).size(), 0u);
  EXPECT_TRUE(bitIdentical(first, surfOf(image)));
}

// FNV-1a over every keypoint's fields and every descriptor byte.
std::uint64_t hashOf(const Features& f) {
  std::uint64_t hash = 1469598103934665603ull;
  const auto add = [&](const void* data, std::size_t bytes) {
    const auto* c = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < bytes; ++i) hash = (hash ^ c[i]) * 1099511628211ull;
  };
  for (const Keypoint& k : f.keypoints) {
    add(&k.x, sizeof k.x);
    add(&k.y, sizeof k.y);
    add(&k.size, sizeof k.size);
    add(&k.angle, sizeof k.angle);
    add(&k.response, sizeof k.response);
    add(&k.octave, sizeof k.octave);
  }
  add(f.descriptors.data, f.descriptors.total() * f.descriptors.elemSize());
  return hash;
}

TEST(SurfBehaviour, FeaturesAreTheOnesStoredMapsWereBuiltFrom) {
  // A map's words and signatures come from these bits: a faster detector or descriptor must
  // give the same ones. The hashes are those every earlier build gave; the small image
  // takes the second search at twice its size.
  const cv::Mat image = blobsOnARamp();
  cv::Mat small;
  cv::resize(image, small, cv::Size(), 0.375, 0.375, cv::INTER_AREA);
  const Features large_features = surfOf(image), small_features = surfOf(small);
  EXPECT_EQ(large_features.size(), 166u);
  EXPECT_EQ(hashOf(large_features), 13812290237754038512ull);
  EXPECT_EQ(small_features.size(), 100u);
  EXPECT_EQ(hashOf(small_features), 4192547597795979090ull);
}

TEST(SurfBehaviour, FlatImageGivesNoFeatures) {
  const Features features = surfOf(cv::Mat(120, 160, CV_8UC1, cv::Scalar(128)));
  EXPECT_EQ(features.size(), 0u);
  EXPECT_EQ(features.dim, 64);
}

}  // namespace
}  // namespace placedb
