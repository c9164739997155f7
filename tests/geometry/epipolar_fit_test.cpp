// The a-contrario epipolar decision: correspondences without a common geometry never pass,
// whatever their number; a rigid scene seen from two poses passes, with few pairs too, at
// 240x192 and at 160x128.
#include <gtest/gtest.h>

#include <random>

#include "epipolar_pairs.h"
#include "geometry/epipolar_fit.h"

namespace placedb {
namespace {

using testing::noise;
using testing::Pairs;
using testing::rigid;

TEST(EpipolarFit, PureNoiseNeverPassesAtAnyMatchCount) {
  const EpipolarFitSettings settings;
  for (cv::Size2f size : {cv::Size2f(240, 192), cv::Size2f(160, 128), cv::Size2f(960, 540)}) {
    for (int n : {8, 9, 10, 12, 15, 20, 30, 50, 100, 200, 400}) {
      for (unsigned seed = 1; seed <= 5; ++seed) {
        std::mt19937 rng(seed * 1000 + static_cast<unsigned>(n));
        const Pairs p = noise(n, size, rng);
        const EpipolarFit fit = fitEpipolar(p.a, p.b, size, settings);
        EXPECT_FALSE(fit.passed) << size.width << "x" << size.height << " n " << n << " seed "
                                 << seed << ": " << fit.inliers << " inliers, log10 NFA "
                                 << fit.log10_nfa;
      }
    }
  }
}

TEST(EpipolarFit, ARigidScenePassesWithFewOrManyPairs) {
  EpipolarFitSettings settings;
  settings.stop_when_passed = false;  // the best model, to look at its inliers
  for (cv::Size2f size : {cv::Size2f(240, 192), cv::Size2f(160, 128)}) {
    for (int n : {10, 12, 20, 60, 200}) {
      std::mt19937 rng(static_cast<unsigned>(n));
      const Pairs p = rigid(n, 0, size, 0.3f, rng);
      const EpipolarFit fit = fitEpipolar(p.a, p.b, size, settings);
      EXPECT_TRUE(fit.passed) << size.width << " n " << n << ": log10 NFA " << fit.log10_nfa;
      EXPECT_GE(fit.inliers, n - 2) << size.width << " n " << n;
    }
  }
}

TEST(EpipolarFit, ARigidSceneAmongOutliersPasses) {
  const cv::Size2f size(240, 192);
  std::mt19937 rng(3);
  // 25 true pairs among 60: the ratio a fixed count of 13 inliers already let through.
  const Pairs p = rigid(60, 35, size, 0.3f, rng);
  EpipolarFitSettings settings;
  settings.iterations = 2000;
  const EpipolarFit fit = fitEpipolar(p.a, p.b, size, settings);
  EXPECT_TRUE(fit.passed) << "log10 NFA " << fit.log10_nfa << ", " << fit.inliers << " inliers";
  EXPECT_GE(fit.inliers, 20);
}

TEST(EpipolarFit, TheChanceLevelFollowsTheEvidence) {
  const cv::Size2f size(240, 192);
  // The same agreement is worth less among more pairs, at a larger distance, on a smaller image.
  EXPECT_LT(epipolarLog10Nfa(20, 12, 1.0, size, 400), epipolarLog10Nfa(60, 12, 1.0, size, 400));
  EXPECT_LT(epipolarLog10Nfa(20, 12, 0.5, size, 400), epipolarLog10Nfa(20, 12, 2.0, size, 400));
  EXPECT_LT(epipolarLog10Nfa(20, 12, 1.0, cv::Size2f(960, 540), 400),
            epipolarLog10Nfa(20, 12, 1.0, size, 400));
  EXPECT_LT(epipolarLog10Nfa(20, 15, 1.0, size, 400), epipolarLog10Nfa(20, 12, 1.0, size, 400));
  EXPECT_GT(epipolarLog10Nfa(8, 8, 1.0, size, 400), 0) << "8 pairs are 1 beyond a sample";
}

TEST(EpipolarFit, AConfidentFitStopsEarlyWithTheAgreementOfEveryDraw) {
  // Comparing views (agreeing_place.h): once a sample of agreeing pairs was surely drawn, the
  // model it gives holds the scene's pairs; the draws left could only add an outlier or two that
  // lie near some line by chance.
  const cv::Size2f size(240, 192);
  for (int outliers : {0, 10, 25}) {
    std::mt19937 rng(static_cast<unsigned>(40 + outliers));
    const Pairs p = rigid(60, outliers, size, 0.3f, rng);
    EpipolarFitSettings every;
    every.stop_when_passed = false;
    EpipolarFitSettings confident = every;
    confident.confidence = 0.99;
    const EpipolarFit full = fitEpipolar(p.a, p.b, size, every);
    const EpipolarFit early = fitEpipolar(p.a, p.b, size, confident);
    EXPECT_LE(early.most_within_max_error, full.most_within_max_error) << outliers << " outliers";
    EXPECT_GE(early.most_within_max_error, 60 - outliers - 2) << outliers << " outliers";
    EXPECT_TRUE(early.passed) << outliers << " outliers";
    EXPECT_EQ(full.draws, every.iterations);
    EXPECT_LT(early.draws, outliers == 0 ? 3 : full.draws) << outliers << " outliers";
  }
  // Unrelated pairs agree with no model beyond chance: the fit is never confident, and draws
  // them all, as without the setting.
  std::mt19937 rng(5);
  const Pairs unrelated = noise(60, size, rng);
  EpipolarFitSettings every;
  every.stop_when_passed = false;
  EpipolarFitSettings confident = every;
  confident.confidence = 0.99;
  const EpipolarFit full = fitEpipolar(unrelated.a, unrelated.b, size, every);
  const EpipolarFit early = fitEpipolar(unrelated.a, unrelated.b, size, confident);
  EXPECT_EQ(early.most_within_max_error, full.most_within_max_error);
  EXPECT_EQ(early.log10_nfa, full.log10_nfa);
  EXPECT_EQ(early.draws, full.draws);
}

TEST(EpipolarFit, IsDeterministic) {
  const cv::Size2f size(240, 192);
  std::mt19937 rng(9);
  const Pairs p = rigid(50, 20, size, 0.5f, rng);
  const EpipolarFit a = fitEpipolar(p.a, p.b, size, EpipolarFitSettings());
  const EpipolarFit b = fitEpipolar(p.a, p.b, size, EpipolarFitSettings());
  EXPECT_EQ(a.inliers, b.inliers);
  EXPECT_EQ(a.log10_nfa, b.log10_nfa);
  EXPECT_EQ(a.inlier_pairs, b.inlier_pairs);
}

}  // namespace
}  // namespace placedb
