// The forest's search is exact about what it promises: the bounded distance never changes a
// comparison against its bound, and a frame's searches give the same words on any thread count.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "vocabulary/kd_forest.h"
#include "vocabulary/slot_store.h"
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

TEST(BoundedDistance, SumsFourLanesInAFixedOrder) {
  // Lane j sums dimensions j, j + 4, ... in turn and the lanes add as (0 + 1) + (2 + 3): every
  // instruction set must give these bits, or words would depend on the machine.
  std::mt19937 rng(3);
  for (int dim : {64, 32, 61}) {
    const cv::Mat a = randomRows(rng, 100, dim), b = randomRows(rng, 100, dim);
    for (int i = 0; i < a.rows; ++i) {
      const float* x = a.ptr<float>(i);
      const float* y = b.ptr<float>(i);
      float lane[4] = {0, 0, 0, 0};
      int d = 0;
      for (; d + 4 <= dim; d += 4)
        for (int j = 0; j < 4; ++j) lane[j] += (x[d + j] - y[d + j]) * (x[d + j] - y[d + j]);
      for (; d < dim; ++d) lane[0] += (x[d] - y[d]) * (x[d] - y[d]);
      EXPECT_EQ(squaredDistance(x, y, dim), (lane[0] + lane[1]) + (lane[2] + lane[3]))
          << "dim " << dim << " row " << i;
    }
  }
}

TEST(ForestSearch, SeveralQueriesAtOnceFindWhatEachFindsAlone) {
  std::mt19937 rng(5);
  const cv::Mat points = randomRows(rng, 3000);
  SlotStore store(kDim);
  KdForest forest(&store, 4, 8, 99);
  for (int i = 0; i < points.rows; ++i) forest.insert(store.add(i, 0, points.ptr<float>(i)));
  const cv::Mat queries = randomRows(rng, 20);
  for (std::size_t k : {1, 2, 5}) {
    for (int checks : {8, 64}) {
      std::vector<std::vector<Neighbor>> together(queries.rows);
      std::vector<const float*> rows;
      std::vector<std::vector<Neighbor>*> outs;
      for (int q = 0; q < queries.rows; ++q) {
        rows.push_back(queries.ptr<float>(q));
        outs.push_back(&together[q]);
      }
      forest.search(rows.data(), outs.data(), rows.size(), k, checks);
      for (int q = 0; q < queries.rows; ++q) {
        std::vector<Neighbor> alone;
        forest.search(queries.ptr<float>(q), k, checks, &alone);
        ASSERT_EQ(together[q].size(), alone.size()) << "k " << k << " checks " << checks;
        for (std::size_t n = 0; n < alone.size(); ++n) {
          EXPECT_EQ(together[q][n].id, alone[n].id);
          EXPECT_EQ(together[q][n].dist2, alone[n].dist2);
        }
      }
    }
  }
}

TEST(ForestInsert, ABatchGrowsTheTreesOneSlotAtATimeWould) {
  std::mt19937 rng(8);
  const cv::Mat points = randomRows(rng, 5000);
  SlotStore one_store(kDim), batch_store(kDim);
  KdForest one(&one_store, 4, 8, 7), batch(&batch_store, 4, 8, 7);
  std::vector<std::uint32_t> slots;
  // Batches of several sizes, so that slots of one batch split leaves that others found.
  const std::size_t sizes[] = {1, 7, 64, 300};
  std::size_t batches = 0;
  for (int i = 0; i < points.rows; ++i) {
    one.insert(one_store.add(i, 0, points.ptr<float>(i)));
    slots.push_back(batch_store.add(i, 0, points.ptr<float>(i)));
    if (slots.size() == sizes[batches % 4] || i + 1 == points.rows) {
      batch.insert(slots.data(), slots.size());
      slots.clear();
      ++batches;
    }
  }
  EXPECT_EQ(batch.internalNodes(), one.internalNodes());
  std::vector<Neighbor> a, b;
  for (int q = 0; q < 50; ++q) {
    one.search(points.ptr<float>(q * 7), 2, 64, &a);
    batch.search(points.ptr<float>(q * 7), 2, 64, &b);
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t n = 0; n < a.size(); ++n) EXPECT_EQ(a[n].id, b[n].id);
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
