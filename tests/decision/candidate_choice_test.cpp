// Which candidates a frame's check sees and in what order, and which one its hypothesis names:
// the first that passes ends the search, a near continuation passes relaxed when nothing else
// does, and a jump away from the ongoing closure has to beat its continuation.
#include <gtest/gtest.h>

#include <map>
#include <optional>
#include <vector>

#include "decision/candidate_choice.h"

namespace placedb {
namespace {

GeometricResult result(int inliers, bool passed) {
  GeometricResult g;
  g.inliers = inliers;
  g.matches = inliers + 5;
  g.log10_nfa = passed ? -4.0 : 1.0;
  g.passed = passed;
  return g;
}

// A check that answers from a table and records what it was asked.
struct FakeCheck {
  std::map<LocationId, GeometricResult> results;
  std::vector<LocationId> asked;
  CandidateCheck fn() {
    return [this](LocationId c) -> std::optional<GeometricResult> {
      asked.push_back(c);
      auto it = results.find(c);
      if (it == results.end()) return std::nullopt;  // no keypoints
      return it->second;
    };
  }
};

bool relaxed(const GeometricResult& g) { return g.inliers >= 7; }

TEST(CandidateOrder, HypothesisFirstThenEverySourceOnceBySimilarity) {
  CandidateSources s;
  s.hypothesis = 10;
  s.around = {11, 12};
  s.most_similar = {30, 11};
  s.searched_back = {40};
  s.near_last_closure = {12, 50};
  const std::map<LocationId, double> eq5{{10, 0.1}, {11, 0.2}, {12, 0.05}, {30, 0.3}, {50, 0.05}};
  const auto similarity = [&eq5](LocationId c) {
    auto it = eq5.find(c);
    return it == eq5.end() ? 0.0 : it->second;
  };
  EXPECT_EQ(orderCandidates(s, similarity), (std::vector<LocationId>{10, 30, 11, 12, 50, 40}));
}

TEST(CandidateOrder, APlaceSearchedBackThisFrameIsCheckedThoughEq5CannotRankIt) {
  // The frame's words were made before the place's words came back, so eq. 5 gives it nothing
  // and it is neither the filter's choice nor among the most similar.
  CandidateSources s;
  s.hypothesis = 3;
  s.most_similar = {4, 5};
  s.searched_back = {77};
  const auto order = orderCandidates(s, [](LocationId c) { return c == 77 ? 0.0 : 0.1; });
  ASSERT_EQ(order.size(), 4u);
  EXPECT_EQ(order.back(), 77);
  FakeCheck check;
  check.results = {
      {3, result(4, false)}, {4, result(5, false)}, {5, result(3, false)}, {77, result(30, true)}};
  const CandidateChoice choice =
      chooseCandidate(order, {}, GeometryRule::kEither, check.fn(), relaxed);
  EXPECT_EQ(choice.location, 77);
  EXPECT_TRUE(choice.passed);
}

TEST(CandidateOrder, NoHypothesisNoCandidates) {
  CandidateSources s;
  s.most_similar = {1, 2};
  EXPECT_TRUE(orderCandidates(s, [](LocationId) { return 1.0; }).empty());
}

TEST(CandidateChoice, FirstPassEndsTheSearch) {
  FakeCheck check;
  check.results = {{10, result(9, false)}, {11, result(20, true)}, {12, result(40, true)}};
  const CandidateChoice c =
      chooseCandidate({10, 11, 12}, {}, GeometryRule::kInliers, check.fn(), relaxed);
  EXPECT_EQ(c.location, 11);
  EXPECT_TRUE(c.passed);
  EXPECT_FALSE(c.temporal);
  EXPECT_EQ(c.checked, 2);
  EXPECT_EQ(check.asked, (std::vector<LocationId>{10, 11}));
}

TEST(CandidateChoice, NothingPassesGivesTheStrongestUnpassed) {
  FakeCheck check;
  check.results = {{10, result(5, false)}, {11, result(9, false)}};
  const CandidateChoice c =
      chooseCandidate({10, 11, 12}, {}, GeometryRule::kInliers, check.fn(), relaxed);
  EXPECT_EQ(c.location, 11);
  EXPECT_FALSE(c.passed);
  EXPECT_EQ(c.checked, 2);  // 12 has no keypoints
}

TEST(CandidateChoice, NearContinuationPassesRelaxedWhenNothingPasses) {
  FakeCheck check;
  check.results = {{10, result(11, false)}, {30, result(8, false)}};
  const CandidateChoice c =
      chooseCandidate({10, 30}, {30, 31}, GeometryRule::kInliers, check.fn(), relaxed);
  EXPECT_EQ(c.location, 30);
  EXPECT_TRUE(c.passed);
  EXPECT_TRUE(c.temporal);
}

TEST(CandidateChoice, JumpThatPassesMeetsTheContinuationItSkipped) {
  // 11 passes first, but the closure was going on at 30-31: the continuation is checked and,
  // passing with as many inliers, kept.
  FakeCheck check;
  check.results = {{10, result(9, false)},
                   {11, result(14, true)},
                   {30, result(14, true)},
                   {31, result(12, false)}};
  const CandidateChoice c =
      chooseCandidate({10, 11, 30, 31}, {30, 31}, GeometryRule::kInliers, check.fn(), relaxed);
  EXPECT_EQ(c.location, 30);
  EXPECT_TRUE(c.passed);
  EXPECT_FALSE(c.temporal);
  EXPECT_EQ(c.checked, 4);
}

TEST(CandidateChoice, ContinuationPassingRelaxedStillBeatsAWeakerJump) {
  FakeCheck check;
  check.results = {{11, result(13, true)}, {30, result(13, false)}};
  const CandidateChoice c =
      chooseCandidate({11, 30}, {30}, GeometryRule::kInliers, check.fn(), relaxed);
  EXPECT_EQ(c.location, 30);
  EXPECT_TRUE(c.passed);
  EXPECT_TRUE(c.temporal);
}

TEST(CandidateChoice, StrongerJumpLeavesTheClosure) {
  FakeCheck check;
  check.results = {{11, result(40, true)}, {30, result(14, true)}};
  const CandidateChoice c =
      chooseCandidate({11, 30}, {30}, GeometryRule::kInliers, check.fn(), relaxed);
  EXPECT_EQ(c.location, 11);
  EXPECT_TRUE(c.passed);
  EXPECT_FALSE(c.temporal);
}

TEST(CandidateChoice, PassingContinuationEndsTheSearchAtOnce) {
  FakeCheck check;
  check.results = {{30, result(14, true)}, {11, result(40, true)}};
  const CandidateChoice c =
      chooseCandidate({30, 11}, {30}, GeometryRule::kInliers, check.fn(), relaxed);
  EXPECT_EQ(c.location, 30);
  EXPECT_EQ(check.asked, (std::vector<LocationId>{30}));
}

}  // namespace
}  // namespace placedb
