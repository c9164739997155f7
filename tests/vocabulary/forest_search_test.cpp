// The forest's search is exact about what it promises: the bounded distance never changes a
// comparison against its bound, and a frame's searches give the same words on any thread count.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "vocabulary/kd_forest.h"
#include "vocabulary/vocabulary.h"

namespace placedb::vocab {
namespace {

constexpr int kDim = 64;  // SURF's, so the 16-dimension blocks and the tail are both exercised

cv::Mat randomRows(std::mt19937& rng, int n, int dim = kDim) {
  std::normal_distribution<float> g(0.f, 0.1f);
  cv::Mat out(n, dim, CV_32F);
  for (int i = 0; i < n; ++i)
    for (int d = 0; d < dim; ++d) out.at<float>(i, d) = g(rng);
  return out;
}

TEST(BoundedDistance, EqualsTheFullSumAtOrBelowTheBoundAndExceedsItAbove) {
  std::mt19937 rng(7);
  for (int dim : {64, 61, 16, 3}) {
    const cv::Mat a = randomRows(rng, 200, dim), b = randomRows(rng, 200, dim);
    for (int i = 0; i < a.rows; ++i) {
      const float full = squaredDistance(a.ptr<float>(i), b.ptr<float>(i), dim);
      for (float bound : {0.f, full * 0.5f, full, full * 2.f}) {
        const float d = squaredDistanceBelow(a.ptr<float>(i), b.ptr<float>(i), dim, bound);
        if (full <= bound)
          EXPECT_EQ(d, full) << "dim " << dim << " row " << i;
        else
          EXPECT_GT(d, bound) << "dim " << dim << " row " << i;
      }
    }
  }
}

std::vector<Quantization> quantizeFrames(int threads) {
  VocabularyOptions o;
  o.threads = threads;
  Vocabulary v(o, kDim, "test");
  std::mt19937 rng(11);
  std::vector<Quantization> out;
  for (int frame = 0; frame < 30; ++frame) out.push_back(v.quantize(randomRows(rng, 150), frame));
  return out;
}

TEST(ParallelQuantization, ChoosesTheSameWordsOnAnyThreadCount) {
  const auto one = quantizeFrames(1);
  for (int threads : {2, 3, 8}) {
    const auto many = quantizeFrames(threads);
    ASSERT_EQ(many.size(), one.size());
    for (std::size_t f = 0; f < one.size(); ++f) {
      EXPECT_EQ(many[f].word_of_feature, one[f].word_of_feature) << threads << " threads, " << f;
      EXPECT_EQ(many[f].distance_of_feature, one[f].distance_of_feature);
      EXPECT_EQ(many[f].created_words, one[f].created_words);
    }
  }
}

}  // namespace
}  // namespace placedb::vocab
