// The code-bounded matcher must find exactly what comparing every pair in full finds: the same
// rows, the same nearest candidate on ties, the same float distances bit for bit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include "geometry/descriptor_match.h"
#include "geometry/geometric_check.h"

namespace placedb {
namespace {

constexpr int kDim = 64;

cv::Mat randomUnitRows(int rows, std::mt19937& rng, int dim = kDim) {
  std::normal_distribution<float> normal(0.f, 1.f);
  cv::Mat d(rows, dim, CV_32F);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < dim; ++c) d.at<float>(r, c) = normal(rng);
    cv::normalize(d.row(r), d.row(r));
  }
  return d;
}

// Candidate rows that the query's rows are near (a revisit), near each other (look-alikes)
// and equal to each other (ties), among unrelated ones.
cv::Mat candidateRows(const cv::Mat& query, std::mt19937& rng) {
  std::normal_distribution<float> noise(0.f, 0.05f);
  cv::Mat c = randomUnitRows(query.rows, rng, query.cols);
  for (int r = 0; r < c.rows; r += 3) {
    for (int k = 0; k < query.cols; ++k) c.at<float>(r, k) = query.at<float>(r, k) + noise(rng);
    cv::normalize(c.row(r), c.row(r));
  }
  for (int r = 1; r + 1 < c.rows; r += 7) c.row(r).copyTo(c.row(r + 1));
  query.row(4).copyTo(c.row(5));  // a distance of 0
  return c;
}

bool sameBits(float a, float b) { return std::memcmp(&a, &b, sizeof(float)) == 0; }

void expectSame(const std::vector<RatioMatch>& got, const std::vector<RatioMatch>& want) {
  ASSERT_EQ(got.size(), want.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].query, want[i].query);
    EXPECT_EQ(got[i].candidate, want[i].candidate) << "query row " << got[i].query;
    EXPECT_TRUE(sameBits(got[i].d1, want[i].d1)) << "query row " << got[i].query;
    EXPECT_TRUE(sameBits(got[i].d2, want[i].d2)) << "query row " << got[i].query;
  }
}

TEST(DescriptorMatch, StoredCodesMatchLikeEveryPairCompared) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 5; ++trial) {
    const cv::Mat query = randomUnitRows(150 + 20 * trial, rng);
    const std::vector<std::uint8_t> bytes = encodeDescriptors(candidateRows(query, rng));
    const cv::Mat decoded = decodeDescriptors(bytes, kDim);
    const DescriptorCodes q = quantiseDescriptors(query, kQueryCodeLevels);
    const DescriptorCodes c = storedDescriptorCodes(bytes, kDim);
    ASSERT_EQ(c.rows, decoded.rows);
    for (float ratio : {0.6f, 0.8f, 1.0f}) {
      const std::vector<RatioMatch> want =
          ratioMatchesBruteForce({&query, nullptr}, {&decoded, nullptr}, ratio * ratio);
      EXPECT_FALSE(want.empty());
      expectSame(ratioMatches({&query, &q}, {nullptr, &c}, ratio * ratio), want);
    }
  }
}

TEST(DescriptorMatch, FloatCandidatesMatchLikeEveryPairCompared) {
  std::mt19937 rng(12);
  const cv::Mat query = randomUnitRows(120, rng);
  const cv::Mat candidate = candidateRows(query, rng);
  const DescriptorCodes q = quantiseDescriptors(query, kQueryCodeLevels);
  const DescriptorCodes c = quantiseDescriptors(candidate, kCandidateCodeLevels);
  expectSame(ratioMatches({&query, &q}, {&candidate, &c}, 0.64f),
             ratioMatchesBruteForce({&query, nullptr}, {&candidate, nullptr}, 0.64f));
}

// Lengths the wide integer loops do not divide (they fall back to narrower ones).
TEST(DescriptorMatch, AnyLengthMatchesLikeEveryPairCompared) {
  std::mt19937 rng(15);
  for (int dim : {72, 60, 128}) {
    const cv::Mat query = randomUnitRows(90, rng, dim);
    const std::vector<std::uint8_t> bytes = encodeDescriptors(candidateRows(query, rng));
    const cv::Mat decoded = decodeDescriptors(bytes, dim);
    const DescriptorCodes q = quantiseDescriptors(query, kQueryCodeLevels);
    const DescriptorCodes c = storedDescriptorCodes(bytes, dim);
    expectSame(ratioMatches({&query, &q}, {nullptr, &c}, 0.64f),
               ratioMatchesBruteForce({&query, nullptr}, {&decoded, nullptr}, 0.64f));
  }
}

// Query rows go two at a time and candidate rows four at a time: odd counts leave tails.
TEST(DescriptorMatch, OddRowCountsMatchLikeEveryPairCompared) {
  std::mt19937 rng(17);
  for (int rows : {7, 37, 91}) {
    const cv::Mat query = randomUnitRows(rows, rng);
    const std::vector<std::uint8_t> bytes =
        encodeDescriptors(candidateRows(query.rowRange(0, std::min(rows, 37)), rng));
    const cv::Mat decoded = decodeDescriptors(bytes, kDim);
    const DescriptorCodes q = quantiseDescriptors(query, kQueryCodeLevels);
    const DescriptorCodes c = storedDescriptorCodes(bytes, kDim);
    expectSame(ratioMatches({&query, &q}, {nullptr, &c}, 0.64f),
               ratioMatchesBruteForce({&query, nullptr}, {&decoded, nullptr}, 0.64f));
  }
}

// Squares in float's denormal range round coarsely: the bounds' absolute floor covers them.
TEST(DescriptorMatch, TinyValuesMatchLikeEveryPairCompared) {
  std::mt19937 rng(16);
  for (float scale : {1e-18f, 1e-20f, 1e-22f}) {
    const cv::Mat query = randomUnitRows(80, rng) * scale;
    const cv::Mat candidate = candidateRows(query / scale, rng) * scale;
    const DescriptorCodes q = quantiseDescriptors(query, kQueryCodeLevels);
    const DescriptorCodes c = quantiseDescriptors(candidate, kCandidateCodeLevels);
    for (float ratio_sq : {0.01f, 0.64f})
      expectSame(ratioMatches({&query, &q}, {&candidate, &c}, ratio_sq),
                 ratioMatchesBruteForce({&query, nullptr}, {&candidate, nullptr}, ratio_sq));
  }
}

TEST(DescriptorMatch, RowsWithoutBoundsAreComparedInFull) {
  std::mt19937 rng(13);
  cv::Mat query = randomUnitRows(40, rng);
  const cv::Mat candidate = candidateRows(query, rng);
  query.row(2).setTo(0.f);  // no scale
  query.at<float>(7, 3) = std::numeric_limits<float>::quiet_NaN();
  query.at<float>(9, 0) = 1e30f;  // a square beyond float
  const DescriptorCodes q = quantiseDescriptors(query, kQueryCodeLevels);
  EXPECT_TRUE(std::isinf(q.error[7]));
  const DescriptorCodes c = quantiseDescriptors(candidate, kCandidateCodeLevels);
  expectSame(ratioMatches({&query, &q}, {&candidate, &c}, 0.64f),
             ratioMatchesBruteForce({&query, nullptr}, {&candidate, nullptr}, 0.64f));
}

TEST(DescriptorMatch, MalformedStoredBytesHaveNoCodes) {
  EXPECT_EQ(storedDescriptorCodes(std::vector<std::uint8_t>(kDim + 3), kDim).rows, 0);
  EXPECT_EQ(storedDescriptorCodes({}, kDim).rows, 0);
}

// The check on a stored location's codes gives what it gave on their decoded floats.
TEST(DescriptorMatch, CheckOnStoredCodesEqualsCheckOnDecodedFloats) {
  std::mt19937 rng(14);
  std::uniform_real_distribution<float> x(0.f, 240.f), y(0.f, 192.f);
  GeometricView query, decoded, coded;
  query.descriptors = randomUnitRows(200, rng);
  const std::vector<std::uint8_t> bytes = encodeDescriptors(candidateRows(query.descriptors, rng));
  decoded.descriptors = decodeDescriptors(bytes, kDim);
  coded.codes = std::make_shared<const DescriptorCodes>(storedDescriptorCodes(bytes, kDim));
  for (int i = 0; i < 200; ++i) {
    query.points.emplace_back(x(rng), y(rng));
    // Candidate points shifted a little: some matches agree on a translation.
    decoded.points.emplace_back(query.points.back() + cv::Point2f(i % 3 == 0 ? 5.f : x(rng), 0));
  }
  coded.points = decoded.points;
  GeometricCheckSettings settings;
  settings.exhaustive = true;
  const GeometricResult want = checkGeometry(query, decoded, settings);
  const GeometricResult got = checkGeometry(query, coded, settings);
  EXPECT_GT(want.matches, 0);
  EXPECT_EQ(got.matches, want.matches);
  EXPECT_EQ(got.inliers, want.inliers);
  EXPECT_EQ(got.log10_nfa, want.log10_nfa);
  EXPECT_EQ(got.passed, want.passed);
  EXPECT_EQ(got.agreeing_query, want.agreeing_query);
}

}  // namespace
}  // namespace placedb
