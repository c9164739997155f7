// The geometric check must pass one rigid scene seen from two poses and refuse the same words
// scattered at unrelated places; unique shared words spare it the descriptor matching.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "geometry/geometric_check.h"

namespace placedb {
namespace {

constexpr int kPoints = 60;
constexpr int kDim = 64;

cv::Mat randomUnitDescriptors(int rows, std::mt19937& rng) {
  std::normal_distribution<float> normal(0.f, 1.f);
  cv::Mat d(rows, kDim, CV_32F);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < kDim; ++c) d.at<float>(r, c) = normal(rng);
    cv::normalize(d.row(r), d.row(r));
  }
  return d;
}

// Pinhole camera (f = 200 px, 240x192 image) at x = tx looking down +z; the scene is 3D points
// 4..12 m ahead. A sideways step gives a real epipolar geometry.
std::vector<cv::Point2f> project(const std::vector<cv::Point3f>& scene, float tx) {
  std::vector<cv::Point2f> out;
  for (const auto& p : scene)
    out.emplace_back(120.f + 200.f * (p.x - tx) / p.z, 96.f + 200.f * p.y / p.z);
  return out;
}

struct TwoViews {
  GeometricView query, candidate;
};

TwoViews rigidScene(std::mt19937& rng) {
  std::uniform_real_distribution<float> x(-2.f, 2.f), y(-1.5f, 1.5f), z(4.f, 12.f);
  std::vector<cv::Point3f> scene;
  for (int i = 0; i < kPoints; ++i) scene.emplace_back(x(rng), y(rng), z(rng));
  TwoViews v;
  v.query.descriptors = randomUnitDescriptors(kPoints, rng);
  v.candidate.descriptors = v.query.descriptors.clone();
  v.query.points = project(scene, 0.f);
  v.candidate.points = project(scene, 0.6f);
  return v;
}

TEST(GeometricCheck, OneRigidSceneFromTwoPosesPasses) {
  std::mt19937 rng(7);
  TwoViews v = rigidScene(rng);
  const GeometricResult r = checkGeometry(v.query, v.candidate, GeometricCheckSettings());
  EXPECT_TRUE(r.passed) << "log10 NFA " << r.log10_nfa;
  EXPECT_EQ(r.matches, kPoints);
  EXPECT_GE(r.inliers, kPoints - 2);  // exact projections: all agree but for rounding
  EXPECT_FALSE(r.from_words) << "no words given: descriptors only";
}

TEST(GeometricCheck, SameWordsAtUnrelatedPlacesFail) {
  std::mt19937 rng(11);
  TwoViews v = rigidScene(rng);
  // Same descriptors, but every keypoint of the candidate lands somewhere random.
  std::uniform_real_distribution<float> u(0.f, 240.f), w(0.f, 192.f);
  for (auto& p : v.candidate.points) p = cv::Point2f(u(rng), w(rng));
  const GeometricResult r = checkGeometry(v.query, v.candidate, GeometricCheckSettings());
  EXPECT_EQ(r.matches, kPoints);
  EXPECT_LT(r.inliers, 20);  // chance agreement, far below the rigid scene's ~60
  GeometricCheckSettings nfa;
  nfa.rule = GeometryRule::kNfa;
  const GeometricResult a = checkGeometry(v.query, v.candidate, nfa);
  EXPECT_FALSE(a.passed) << a.inliers << " inliers, log10 NFA " << a.log10_nfa;
}

TEST(GeometricCheck, BothRulesPassARigidScene) {
  std::mt19937 rng(23);
  TwoViews v = rigidScene(rng);
  for (GeometryRule rule : {GeometryRule::kInliers, GeometryRule::kNfa, GeometryRule::kEither}) {
    GeometricCheckSettings settings;
    settings.rule = rule;
    const GeometricResult r = checkGeometry(v.query, v.candidate, settings);
    EXPECT_TRUE(r.passed) << static_cast<int>(rule);
    EXPECT_GE(r.inliers, settings.min_inliers);
  }
}

TEST(GeometricCheck, UniqueSharedWordsPassWithoutDescriptorMatching) {
  std::mt19937 rng(13);
  TwoViews v = rigidScene(rng);
  for (int i = 0; i < kPoints; ++i) {
    v.query.words.push_back(1000 + i);
    v.candidate.words.push_back(1000 + i);
  }
  // The descriptors disagree: only the words can pair the keypoints.
  v.candidate.descriptors = randomUnitDescriptors(kPoints, rng);
  const GeometricResult r = checkGeometry(v.query, v.candidate, GeometricCheckSettings());
  EXPECT_TRUE(r.passed);
  EXPECT_TRUE(r.from_words);
  EXPECT_EQ(r.matches, kPoints);
}

TEST(GeometricCheck, RepeatedWordsPairNothing) {
  std::mt19937 rng(17);
  TwoViews v = rigidScene(rng);
  for (int i = 0; i < kPoints; ++i) {
    v.query.words.push_back(1000 + i / 2);  // every word twice
    v.candidate.words.push_back(1000 + i / 2);
  }
  v.candidate.descriptors = randomUnitDescriptors(kPoints, rng);
  const GeometricResult r = checkGeometry(v.query, v.candidate, GeometricCheckSettings());
  EXPECT_FALSE(r.from_words);
  EXPECT_FALSE(r.passed);
}

TEST(GeometricCheck, EitherRulePassesFewPairsWithStrongEvidence) {
  std::mt19937 rng(29);
  TwoViews v = rigidScene(rng);
  // 10 exact pairs: below the 13 inliers the count asks, far beyond chance.
  v.query.points.resize(10);
  v.candidate.points.resize(10);
  v.query.descriptors = v.query.descriptors.rowRange(0, 10).clone();
  v.candidate.descriptors = v.candidate.descriptors.rowRange(0, 10).clone();
  GeometricCheckSettings settings;
  settings.rule = GeometryRule::kInliers;
  settings.max_nfa = 1e-3;
  settings.min_overlap = 0;
  EXPECT_FALSE(checkGeometry(v.query, v.candidate, settings).passed) << "inliers rule";
  settings.rule = GeometryRule::kEither;
  const GeometricResult r = checkGeometry(v.query, v.candidate, settings);
  EXPECT_TRUE(r.passed) << "log10 NFA " << r.log10_nfa;
}

TEST(GeometricCheck, AgreementDistanceIsAShareOfTheDiagonalOnSmallImages) {
  GeometricCheckSettings settings;  // 3 px, at most 1 % of the diagonal
  EXPECT_DOUBLE_EQ(agreementDistance(settings, cv::Size(240, 192)), 3.0);
  EXPECT_DOUBLE_EQ(agreementDistance(settings, cv::Size(960, 540)), 3.0);
  EXPECT_NEAR(agreementDistance(settings, cv::Size(120, 96)), 0.01 * std::hypot(120, 96), 1e-12);
  EXPECT_DOUBLE_EQ(agreementDistance(settings, cv::Size()), 3.0) << "size unknown: pixels alone";
  settings.max_error_diagonal = 0;
  EXPECT_DOUBLE_EQ(agreementDistance(settings, cv::Size(120, 96)), 3.0);
}

TEST(GeometricCheck, ASmallImageCountsOnlyCloseAgreement) {
  std::mt19937 rng(31);
  TwoViews v = rigidScene(rng);
  // The same scene on a 120x96 sensor, the candidate's keypoints 1.6-2.6 px off: within 3 px of
  // their epipolar lines, as chance pairs would be twice as often on this image as on 240x192.
  std::uniform_real_distribution<float> radius(1.6f, 2.6f), angle(0.f, 6.2831853f);
  for (auto* points : {&v.query.points, &v.candidate.points})
    for (auto& p : *points) p *= 0.5f;
  for (auto& p : v.candidate.points) {
    const float r = radius(rng), a = angle(rng);
    p += cv::Point2f(r * std::cos(a), r * std::sin(a));
  }
  GeometricCheckSettings settings;
  settings.rule = GeometryRule::kInliers;
  settings.exhaustive = true;
  const GeometricResult in_pixels = checkGeometry(v.query, v.candidate, settings);
  v.query.image_size = cv::Size(120, 96);
  const GeometricResult in_share = checkGeometry(v.query, v.candidate, settings);
  EXPECT_TRUE(in_pixels.passed) << in_pixels.inliers << " inliers";
  EXPECT_LT(in_share.inliers, in_pixels.inliers);
}

TEST(GeometricCheck, TooLittleOverlapFails) {
  std::mt19937 rng(19);
  TwoViews v = rigidScene(rng);
  GeometricCheckSettings settings;
  settings.rule = GeometryRule::kNfa;
  settings.min_overlap = 0.5;
  // 60 views of one scene, but each image has 200 keypoints of which the scene is 30 %.
  std::uniform_real_distribution<float> u(0.f, 240.f), w(0.f, 192.f);
  for (GeometricView* view : {&v.query, &v.candidate}) {
    cv::vconcat(view->descriptors, randomUnitDescriptors(140, rng), view->descriptors);
    for (int i = 0; i < 140; ++i) view->points.emplace_back(u(rng), w(rng));
  }
  const GeometricResult r = checkGeometry(v.query, v.candidate, settings);
  EXPECT_EQ(r.keypoints, 200);
  EXPECT_FALSE(r.passed) << r.inliers << " inliers need 100";
  settings.min_overlap = 0.2;
  EXPECT_TRUE(checkGeometry(v.query, v.candidate, settings).passed);
}

TEST(GeometricCheck, AmbiguousDescriptorsGiveNoMatches) {
  std::mt19937 rng(3);
  TwoViews v = rigidScene(rng);
  // Each candidate descriptor twice: nearest and second nearest tie, the ratio test refuses all.
  cv::vconcat(v.candidate.descriptors, v.candidate.descriptors, v.candidate.descriptors);
  auto points = v.candidate.points;
  v.candidate.points.insert(v.candidate.points.end(), points.begin(), points.end());
  const GeometricResult r = checkGeometry(v.query, v.candidate, GeometricCheckSettings());
  EXPECT_EQ(r.matches, 0);
  EXPECT_EQ(r.inliers, 0);
}

TEST(GeometricCheck, IsDeterministic) {
  std::mt19937 rng(5);
  TwoViews v = rigidScene(rng);
  std::uniform_real_distribution<float> u(0.f, 240.f), w(0.f, 192.f);
  for (int i = 0; i < kPoints / 2; ++i) v.candidate.points[i] = cv::Point2f(u(rng), w(rng));
  const GeometricResult a = checkGeometry(v.query, v.candidate, GeometricCheckSettings());
  const GeometricResult b = checkGeometry(v.query, v.candidate, GeometricCheckSettings());
  EXPECT_EQ(a.inliers, b.inliers);  // a resumed run must repeat every decision
  EXPECT_EQ(a.log10_nfa, b.log10_nfa);
  EXPECT_TRUE(a.passed);
  EXPECT_GE(a.inliers, GeometricCheckSettings().min_inliers);  // the search stops there
}

TEST(GeometricCheck, TheSameViewAgainPasses) {
  // Pairs that did not move fit every skew-symmetric fundamental matrix: no single model wins,
  // yet the same image again is the surest revisit there is.
  std::mt19937 rng(31);
  TwoViews v = rigidScene(rng);
  v.candidate = v.query;
  const GeometricResult r = checkGeometry(v.query, v.candidate, GeometricCheckSettings());
  EXPECT_TRUE(r.passed);
  EXPECT_GE(r.inliers, static_cast<int>(v.query.points.size()) / 2);
}

TEST(GeometricCheck, ExhaustiveCountsEveryInlierForRanking) {
  // Mapping stops at the first model that meets the rule; ranking candidates (query) needs the
  // whole count, or every passing candidate would tie near min_inliers.
  std::mt19937 rng(37);
  TwoViews v = rigidScene(rng);
  // A quarter of the keypoints share a word: enough to pass on words alone.
  for (std::size_t i = 0; i < v.query.points.size(); ++i) {
    const std::int64_t word = i < v.query.points.size() / 4 ? 1000 + std::int64_t(i) : -1;
    v.query.words.push_back(word);
    v.candidate.words.push_back(word);
  }
  GeometricCheckSettings settings;
  settings.rule = GeometryRule::kInliers;
  const GeometricResult quick = checkGeometry(v.query, v.candidate, settings);
  settings.exhaustive = true;
  const GeometricResult full = checkGeometry(v.query, v.candidate, settings);
  ASSERT_TRUE(quick.passed);
  EXPECT_TRUE(full.passed);
  EXPECT_GE(full.inliers, quick.inliers);
  EXPECT_LT(quick.inliers, static_cast<int>(v.query.points.size()) / 2) << "words alone";
  EXPECT_GT(full.inliers, static_cast<int>(v.query.points.size()) * 3 / 4);
}

}  // namespace
}  // namespace placedb
