// Which candidate a frame's hypothesis names: the first that passes ends the search, a near
// continuation passes relaxed when nothing else does, and a jump away from the ongoing closure
// has to beat its continuation.
#include <gtest/gtest.h>

#include <map>
#include <optional>
#include <vector>

#include "engine/candidate_choice.h"

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
