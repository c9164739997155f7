// Hand-built descriptors that pin every branch of the greedy rule (paper 000, algorithm 3) and of
// the NNDR rule (algorithms 1-2), the distance unit, fixed mode and the empty vocabulary.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "placedb/error.h"
#include "vocabulary/vocabulary.h"

namespace placedb::vocab {
namespace {

constexpr int kDim = 4;

cv::Mat rows(const std::vector<std::vector<float>>& values) {
  cv::Mat m(int(values.size()), kDim, CV_32F, cv::Scalar(0));
  for (std::size_t i = 0; i < values.size(); ++i) {
    for (std::size_t d = 0; d < values[i].size(); ++d) m.at<float>(int(i), int(d)) = values[i][d];
  }
  return m;
}

// Euclidean unit so that the thresholds read as plain distances in the cases below.
VocabularyOptions euclidean(WordRule rule) {
  VocabularyOptions o;
  o.rule = rule;
  o.unit = DistanceUnit::kEuclidean;
  o.t_nd1 = 0.1f;
  o.t_nd2 = 0.5f;
  o.t_nndr = 0.8f;
  o.checks = 1000;  // exact on these tiny vocabularies
  return o;
}

// A vocabulary holding `words` as ids 0, 1, ...
Vocabulary withWords(const VocabularyOptions& o, const std::vector<std::vector<float>>& words) {
  Vocabulary v(o, kDim, "test");
  std::vector<std::int64_t> ids, frames;
  for (std::size_t i = 0; i < words.size(); ++i) {
    ids.push_back(std::int64_t(i));
    frames.push_back(0);
  }
  v.insert(ids, rows(words), frames);
  return v;
}

TEST(GreedyRule, NdAboveTnd2CreatesAWordEvenWhenTheRatioIsSmall) {
  // ND = 0.6 > T_ND2 = 0.5; ND/NND = 0.6/9.4 would make NNDR take word 0.
  const std::vector<std::vector<float>> words = {{0, 0, 0, 0}, {10, 0, 0, 0}};
  Vocabulary greedy = withWords(euclidean(WordRule::kGreedy), words);
  Quantization q = greedy.quantize(rows({{0.6f, 0, 0, 0}}), 7);
  EXPECT_EQ(q.word_of_feature, std::vector<std::int64_t>({2}));
  EXPECT_EQ(q.created_words, std::vector<std::int64_t>({2}));
  EXPECT_EQ(q.distance_of_feature[0], 0.f);
  EXPECT_TRUE(greedy.contains(2));
  EXPECT_EQ(greedy.createdFrame(2), 7);
  EXPECT_EQ(greedy.nextWordId(), 3);

  Vocabulary nndr = withWords(euclidean(WordRule::kNndr), words);
  q = nndr.quantize(rows({{0.6f, 0, 0, 0}}), 7);
  EXPECT_EQ(q.word_of_feature, std::vector<std::int64_t>({0}));
  EXPECT_TRUE(q.created_words.empty());
  EXPECT_NEAR(q.distance_of_feature[0], 0.6f, 1e-6);
}

TEST(GreedyRule, NdBelowTnd1TakesTheNearestWordEvenWhenTheRatioIsHigh) {
  // Feature at 0.05: ND = 0.045 (word 1), NND = 0.05 (word 0), ratio 0.9 > T_NNDR.
  const std::vector<std::vector<float>> words = {{0, 0, 0, 0}, {0.095f, 0, 0, 0}};
  Vocabulary greedy = withWords(euclidean(WordRule::kGreedy), words);
  Quantization q = greedy.quantize(rows({{0.05f, 0, 0, 0}}), 1);
  EXPECT_EQ(q.word_of_feature, std::vector<std::int64_t>({1}));
  EXPECT_TRUE(q.created_words.empty());
  EXPECT_NEAR(q.mean_error, 0.045, 1e-6);

  Vocabulary nndr = withWords(euclidean(WordRule::kNndr), words);
  q = nndr.quantize(rows({{0.05f, 0, 0, 0}}), 1);
  EXPECT_EQ(q.created_words, std::vector<std::int64_t>({2}));
  EXPECT_EQ(q.word_of_feature, std::vector<std::int64_t>({2}));
}

TEST(BothRules, AmbiguousMiddleDistanceCreatesAWord) {
  // ND = 0.24 in [T_ND1, T_ND2], NND = 0.26: ratio 0.92 > 0.8.
  for (WordRule rule : {WordRule::kGreedy, WordRule::kNndr}) {
    Vocabulary v = withWords(euclidean(rule), {{0, 0, 0, 0}, {0.5f, 0, 0, 0}});
    Quantization q = v.quantize(rows({{0.24f, 0, 0, 0}}), 1);
    EXPECT_EQ(q.created_words, std::vector<std::int64_t>({2})) << toString(rule);
    EXPECT_EQ(v.size(), 3u);
  }
}

TEST(BothRules, DistinctiveMiddleDistanceTakesTheNearestWord) {
  // ND = 0.3, NND = 0.7: ratio 0.43 <= 0.8.
  for (WordRule rule : {WordRule::kGreedy, WordRule::kNndr}) {
    Vocabulary v = withWords(euclidean(rule), {{0, 0, 0, 0}, {1, 0, 0, 0}});
    Quantization q = v.quantize(rows({{0.3f, 0, 0, 0}}), 1);
    EXPECT_EQ(q.word_of_feature, std::vector<std::int64_t>({0})) << toString(rule);
    EXPECT_TRUE(q.created_words.empty());
    EXPECT_NEAR(q.distance_of_feature[0], 0.3f, 1e-6);
  }
}

TEST(GreedyRule, RefinesWithWordsCreatedEarlierFromTheSameImage) {
  // Both features are far from V_{t-1} (ND 2.0 and 1.95 > T_ND2). The one with the larger ND goes
  // first and creates word 1; the other then finds it at 0.05 < T_ND1 and takes it.
  for (bool reversed : {false, true}) {
    Vocabulary v = withWords(euclidean(WordRule::kGreedy), {{0, 0, 0, 0}});
    std::vector<std::vector<float>> features = {{0, 0, 0, 1.95f}, {0, 0, 0, 2}};
    if (reversed) std::reverse(features.begin(), features.end());
    Quantization q = v.quantize(rows(features), 3);
    EXPECT_EQ(q.created_words, std::vector<std::int64_t>({1}));
    EXPECT_EQ(q.word_of_feature, std::vector<std::int64_t>({1, 1}));
    const int far_one = reversed ? 0 : 1;
    EXPECT_EQ(q.distance_of_feature[far_one], 0.f);
    EXPECT_NEAR(q.distance_of_feature[1 - far_one], 0.05f, 1e-6);
    EXPECT_NEAR(q.mean_error, 0.025, 1e-6);
  }
}

// Paper 000, fig. 1: NNDR's words depend on the processing order, greedy's do not.
// Words 0 = (0) and 1 = (2); features P1 = (1) (halfway: ratio 1) and P2 = (1.3).
TEST(Figure1, NndrDependsOnFeatureOrderGreedyDoesNot) {
  const std::vector<std::vector<float>> words = {{0, 0, 0, 0}, {2, 0, 0, 0}};
  const std::vector<float> p1 = {1, 0, 0, 0}, p2 = {1.3f, 0, 0, 0};

  // NNDR, order P1, P2: P1 creates word 2; P2 then sees it at 0.3 vs word 1 at 0.7 and takes it.
  Vocabulary forward = withWords(euclidean(WordRule::kNndr), words);
  Quantization q = forward.quantize(rows({p1, p2}), 1);
  EXPECT_EQ(q.word_of_feature, std::vector<std::int64_t>({2, 2}));
  // NNDR, order P2, P1: P2 sees words 1 and 0 at 0.7 / 1.3 and takes word 1; P1 creates word 2.
  Vocabulary backward = withWords(euclidean(WordRule::kNndr), words);
  q = backward.quantize(rows({p2, p1}), 1);
  EXPECT_EQ(q.word_of_feature, std::vector<std::int64_t>({1, 2}));

  // Greedy processes P1 (ND 1.0) before P2 (ND 0.7) whatever the input order.
  for (bool reversed : {false, true}) {
    Vocabulary greedy = withWords(euclidean(WordRule::kGreedy), words);
    q = greedy.quantize(reversed ? rows({p2, p1}) : rows({p1, p2}), 1);
    EXPECT_EQ(q.word_of_feature, std::vector<std::int64_t>({2, 2}));
    EXPECT_EQ(q.created_words, std::vector<std::int64_t>({2}));
  }
}

TEST(GreedyRule, ResultIsIndependentOfFeatureOrderOnRandomImages) {
  std::mt19937 rng(5);
  std::normal_distribution<float> gauss(0.f, 1.f);
  cv::Mat words(200, kDim, CV_32F), image(120, kDim, CV_32F);
  for (int i = 0; i < words.rows; ++i)
    for (int d = 0; d < kDim; ++d) words.at<float>(i, d) = gauss(rng);
  for (int i = 0; i < image.rows; ++i)
    for (int d = 0; d < kDim; ++d) image.at<float>(i, d) = gauss(rng);
  std::vector<std::int64_t> ids(words.rows), frames(words.rows, 0);
  for (int i = 0; i < words.rows; ++i) ids[i] = i;
  VocabularyOptions o;  // defaults: greedy, squared unit
  o.checks = 100000;
  o.t_nd2 = 0.3f;

  Vocabulary a(o, kDim, "test"), b(o, kDim, "test");
  a.insert(ids, words, frames);
  b.insert(ids, words, frames);
  std::vector<int> perm(image.rows);
  for (int i = 0; i < image.rows; ++i) perm[i] = i;
  std::shuffle(perm.begin(), perm.end(), rng);
  cv::Mat shuffled(image.rows, kDim, CV_32F);
  for (int i = 0; i < image.rows; ++i) image.row(perm[i]).copyTo(shuffled.row(i));

  const Quantization qa = a.quantize(image, 1);
  const Quantization qb = b.quantize(shuffled, 1);
  ASSERT_FALSE(qa.created_words.empty());
  ASSERT_LT(qa.created_words.size(), std::size_t(image.rows));  // some features reuse words
  EXPECT_EQ(qa.created_words, qb.created_words);
  for (int i = 0; i < image.rows; ++i) {
    EXPECT_EQ(qa.word_of_feature[perm[i]], qb.word_of_feature[i]);
    EXPECT_EQ(qa.distance_of_feature[perm[i]], qb.distance_of_feature[i]);
  }
}

TEST(EmptyVocabulary, FirstFeaturesCreateWords) {
  const std::vector<std::vector<float>> features = {{0, 0, 0, 0}, {5, 0, 0, 0}, {0.01f, 0, 0, 0}};
  // Greedy: all ND = +inf, ties ordered by descriptor: (0) creates 0, (0.01) is within T_ND1 of
  // it, (5) is beyond T_ND2 and creates 1.
  Vocabulary greedy(euclidean(WordRule::kGreedy), kDim, "test");
  Quantization q = greedy.quantize(rows(features), 0);
  EXPECT_EQ(q.word_of_feature, std::vector<std::int64_t>({0, 1, 0}));
  // NNDR: the first feature creates word 0; the second has a single candidate, so the ratio
  // cannot be tested and it creates word 1; the third is far nearer word 0 than word 1.
  Vocabulary nndr(euclidean(WordRule::kNndr), kDim, "test");
  q = nndr.quantize(rows(features), 0);
  EXPECT_EQ(q.word_of_feature, std::vector<std::int64_t>({0, 1, 0}));
  EXPECT_NEAR(q.mean_error, 0.01 / 3, 1e-6);
}

TEST(FixedMode, CreatesNothingAndTakesNearestWords) {
  VocabularyOptions o = euclidean(WordRule::kGreedy);
  o.fixed = true;
  Vocabulary v = withWords(o, {{0, 0, 0, 0}, {1, 0, 0, 0}});
  Quantization q = v.quantize(rows({{0, 0, 0, 9}, {0.9f, 0, 0, 0}, {0.5f, 0, 0, 0}}), 1);
  EXPECT_TRUE(q.created_words.empty());
  EXPECT_EQ(q.word_of_feature, std::vector<std::int64_t>({0, 1, 0}));  // 0.5 tie -> smaller id
  EXPECT_EQ(v.size(), 2u);
  EXPECT_EQ(v.nextWordId(), 2);
  EXPECT_NEAR(q.mean_error, (9.0 + 0.1 + 0.5) / 3, 1e-5);

  Vocabulary empty(o, kDim, "test");
  q = empty.quantize(rows({{1, 2, 3, 4}}), 1);
  EXPECT_EQ(q.word_of_feature, std::vector<std::int64_t>({-1}));
  EXPECT_EQ(empty.size(), 0u);
}

TEST(DistanceUnit, SquaredUnitComparesSquaredDistances) {
  // ND = 0.6: above T_ND2 = 0.5 in Euclidean units, 0.36 below it in squared units.
  VocabularyOptions o = euclidean(WordRule::kGreedy);
  o.unit = DistanceUnit::kSquared;
  Vocabulary v = withWords(o, {{0, 0, 0, 0}, {10, 0, 0, 0}});
  Quantization q = v.quantize(rows({{0.6f, 0, 0, 0}}), 1);
  EXPECT_EQ(q.word_of_feature, std::vector<std::int64_t>({0}));
  EXPECT_NEAR(q.distance_of_feature[0], 0.6f, 1e-6);  // reported in Euclidean units
  // The ratio is of squared distances too: 0.45^2 / 0.55^2 = 0.67 <= 0.8 takes word 0 while the
  // Euclidean ratio 0.82 would create a word.
  Vocabulary w = withWords(o, {{0, 0, 0, 0}, {1, 0, 0, 0}});
  q = w.quantize(rows({{0.45f, 0, 0, 0}}), 1);
  EXPECT_EQ(q.word_of_feature, std::vector<std::int64_t>({0}));
  Vocabulary e = withWords(euclidean(WordRule::kGreedy), {{0, 0, 0, 0}, {1, 0, 0, 0}});
  q = e.quantize(rows({{0.45f, 0, 0, 0}}), 1);
  EXPECT_EQ(q.created_words, std::vector<std::int64_t>({2}));
}

TEST(Options, ValidateRejectsOutOfRangeSettings) {
  auto expectInvalid = [](VocabularyOptions o) {
    try {
      o.validate();
      ADD_FAILURE() << "accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    }
  };
  VocabularyOptions o;
  EXPECT_NO_THROW(o.validate());
  o.t_nndr = -0.1f;
  expectInvalid(o);
  o = {};
  o.t_nd2 = 0.0001f;  // below t_nd1
  expectInvalid(o);
  o = {};
  o.kd_trees = 0;
  expectInvalid(o);
  o = {};
  o.checks = 0;
  expectInvalid(o);
  o = {};
  o.leaf_size = 0;
  expectInvalid(o);
  EXPECT_THROW(Vocabulary(VocabularyOptions{}, 0, "x"), Error);
  Vocabulary v(VocabularyOptions{}, kDim, "x");
  EXPECT_THROW(v.quantize(cv::Mat(2, kDim + 1, CV_32F, cv::Scalar(0)), 0), Error);
  cv::Mat nan_row = rows({{0, 0, 0, 0}, {1, 0, 0, 0}});
  nan_row.at<float>(1, 2) = std::nanf("");
  EXPECT_THROW(v.quantize(nan_row, 0), Error);
  EXPECT_EQ(v.size(), 0u);
}

}  // namespace
}  // namespace placedb::vocab
