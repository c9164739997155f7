// Whether a frame shares a scene with a place or only an object (scene_extent.h): pairs on planes
// make the regions, chance pairs do not, and a patch is refused where a scene passes.
#include <gtest/gtest.h>

#include <random>

#include "geometry/geometric_check.h"
#include "geometry/scene_extent.h"

namespace placedb {
namespace {

constexpr float kWidth = 320, kHeight = 240;

// n pairs on one plane: a point of the query image and its image under a homography that moves
// the view a little, as a frame and another view of the same wall or floor.
void addPlane(GeometricResult& g, cv::Rect2f region, int n, std::mt19937& rng) {
  std::uniform_real_distribution<float> x(region.x, region.x + region.width);
  std::uniform_real_distribution<float> y(region.y, region.y + region.height);
  const cv::Matx33d h(1.05, 0.02, 6, -0.01, 1.03, 4, 1e-5, 2e-5, 1);
  for (int i = 0; i < n; ++i) {
    const cv::Point2f q(x(rng), y(rng));
    const cv::Vec3d m = h * cv::Vec3d(q.x, q.y, 1);
    g.agreeing_query.push_back(q);
    g.agreeing_candidate.emplace_back(static_cast<float>(m[0] / m[2]),
                                      static_cast<float>(m[1] / m[2]));
  }
}

// Pairs that agree with no plane: each candidate point anywhere.
void addChance(GeometricResult& g, int n, std::mt19937& rng) {
  std::uniform_real_distribution<float> x(0, kWidth), y(0, kHeight);
  for (int i = 0; i < n; ++i) {
    g.agreeing_query.emplace_back(x(rng), y(rng));
    g.agreeing_candidate.emplace_back(x(rng), y(rng));
  }
}

const cv::Rect2f kWholeImage(10, 10, kWidth - 20, kHeight - 20);

TEST(SceneExtent, PairsOnTwoPlanesAreFoundAndChancePairsAreNot) {
  std::mt19937 rng(3);
  GeometricResult g;
  addPlane(g, {10, 10, 100, 200}, 12, rng);
  addChance(g, 5, rng);
  // A second plane: the same region seen under another motion.
  const cv::Matx33d other(0.97, 0, -8, 0, 0.98, 2, 0, 0, 1);
  for (int i = 0; i < 10; ++i) {
    const cv::Point2f q(200.f + 9 * i, 30.f + 17 * (i % 5));
    const cv::Vec3d m = other * cv::Vec3d(q.x, q.y, 1);
    g.agreeing_query.push_back(q);
    g.agreeing_candidate.emplace_back(static_cast<float>(m[0]), static_cast<float>(m[1]));
  }
  const std::vector<int> planar = planarPairs(g.agreeing_query, g.agreeing_candidate, 3.0);
  EXPECT_GE(planar.size(), 20u) << "nearly all of both planes' 22 pairs";
  for (int i : planar) EXPECT_TRUE(i < 12 || i >= 17) << "chance pair " << i << " on a plane";
  EXPECT_EQ(planarPairs(g.agreeing_query, g.agreeing_candidate, 3.0), planar) << "deterministic";
}

TEST(SceneExtent, HullAreaOfChosenPoints) {
  const std::vector<cv::Point2f> p{{0, 0}, {10, 0}, {10, 10}, {0, 10}, {5, 5}, {100, 100}};
  EXPECT_DOUBLE_EQ(hullArea(p, {0, 1, 2, 3, 4}), 100.0);
  EXPECT_DOUBLE_EQ(hullArea(p, {0, 1}), 0.0) << "fewer than three points span nothing";
}

TEST(SceneExtent, OneObjectInABigSceneIsRefusedAndASharedSceneIsNot) {
  std::mt19937 rng(5);
  GeometricResult own_view;  // the frame agrees with its previous view all over the image
  addPlane(own_view, kWholeImage, 80, rng);
  GeometricResult object;  // a poster: many pairs, all on one small patch
  addPlane(object, {150, 60, 50, 40}, 40, rng);
  addChance(object, 2, rng);  // and the chance pairs an epipolar fit takes in
  const SceneShare patch = sceneShare(object, &own_view, 3.0);
  ASSERT_TRUE(patch.measured);
  EXPECT_LT(patch.share, 0.25) << "a patch of 3 % of the scene";
  EXPECT_EQ(patch.place_pairs, 40) << "the chance pairs do not widen it";

  GeometricResult place;  // a revisit: fewer pairs, spread over half the view
  addPlane(place, {10, 10, 150, kHeight - 20}, 15, rng);
  const SceneShare shared = sceneShare(place, &own_view, 3.0);
  ASSERT_TRUE(shared.measured);
  EXPECT_GE(shared.share, 0.25);
}

TEST(SceneExtent, FewPairsAreGivenTheRegionTheyCouldComeFrom) {
  // Eight pairs spread over a third of the scene span less than that third by chance; the
  // share allows for it, so a sparse revisit is not taken for an object.
  std::mt19937 rng(8);
  GeometricResult own_view;
  addPlane(own_view, kWholeImage, 80, rng);
  GeometricResult sparse;
  addPlane(sparse, {10, 10, kWidth / 3, kHeight - 20}, 8, rng);
  const SceneShare s = sceneShare(sparse, &own_view, 3.0);
  EXPECT_GT(s.share, s.place_area / s.scene_area) << "more than the bare ratio of the hulls";
  EXPECT_GE(s.share, 0.25);
}

TEST(SceneExtent, NoOwnViewMeansNothingIsMeasured) {
  std::mt19937 rng(9);
  GeometricResult object;
  addPlane(object, {150, 60, 50, 40}, 30, rng);
  EXPECT_FALSE(sceneShare(object, nullptr, 3.0).measured) << "a session's first frame";
  GeometricResult blurred;  // the previous view agrees on too few pairs to show a scene
  addPlane(blurred, kWholeImage, kMinPlanePairs - 1, rng);
  EXPECT_FALSE(sceneShare(object, &blurred, 3.0).measured);
}

// The check's false alarms are counted over the places the frame chose among.
TEST(CandidateCount, AFitThatPassesAloneFailsAmongManyPlaces) {
  std::mt19937 rng(13);
  std::uniform_real_distribution<float> x(0, 240), y(0, 192), jitter(-0.5f, 0.5f);
  GeometricView query, candidate;
  // 11 pairs of which 10 agree with a translation (a still camera moved sideways) and one not:
  // a weak fit whose NFA lies between the bars of one place and of a thousand.
  for (int i = 0; i < 11; ++i) {
    const cv::Point2f p(x(rng), y(rng));
    query.points.push_back(p);
    candidate.points.push_back(i == 0 ? cv::Point2f(x(rng), y(rng))
                                      : p + cv::Point2f(20 + jitter(rng), jitter(rng)));
  }
  query.descriptors = cv::Mat::eye(11, 64, CV_32F);
  candidate.descriptors = query.descriptors.clone();
  GeometricCheckSettings one;
  one.rule = GeometryRule::kNfa;
  one.min_overlap = 0;
  one.exhaustive = true;  // the best model's NFA, not the first that passes
  const GeometricResult alone = checkGeometry(query, candidate, one);
  ASSERT_TRUE(alone.passed) << "log10 NFA " << alone.log10_nfa;
  GeometricCheckSettings many = one;
  many.tests = static_cast<int>(std::ceil(std::pow(10.0, -3 - alone.log10_nfa))) + 1;
  EXPECT_FALSE(checkGeometry(query, candidate, many).passed)
      << "over " << many.tests << " places the same fit is within chance";
}

TEST(CandidateCount, TheInliersRuleRefusesACountThatChanceGivesAsOften) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> x(0, 240), y(0, 192), jitter(-0.5f, 0.5f);
  GeometricView query, candidate;
  // 14 agreeing pairs among 60: the count passes, the NFA of so few among so many does not.
  for (int i = 0; i < 60; ++i) {
    const cv::Point2f p(x(rng), y(rng));
    query.points.push_back(p);
    candidate.points.push_back(i < 14 ? p + cv::Point2f(15 + jitter(rng), jitter(rng))
                                      : cv::Point2f(x(rng), y(rng)));
  }
  query.descriptors = cv::Mat::eye(60, 64, CV_32F);
  candidate.descriptors = query.descriptors.clone();
  GeometricCheckSettings count;
  count.rule = GeometryRule::kInliers;
  const GeometricResult plain = checkGeometry(query, candidate, count);
  ASSERT_TRUE(plain.passed) << plain.inliers << " inliers";
  count.count_max_nfa = 1;
  count.tests = 20;
  const GeometricResult counted = checkGeometry(query, candidate, count);
  EXPECT_EQ(counted.passed, counted.log10_nfa + std::log10(20.0) <= 0)
      << counted.inliers << " inliers, log10 NFA " << counted.log10_nfa;
}

}  // namespace
}  // namespace placedb
