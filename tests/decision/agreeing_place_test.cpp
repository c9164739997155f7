// The place an accepted closure names: of the accepted place and its traversal neighbours, the
// one with strictly the most agreeing pairs; a tie, or a neighbour that cannot be compared,
// leaves the closure where it was accepted.
#include <gtest/gtest.h>

#include <map>
#include <optional>
#include <vector>

#include "decision/agreeing_place.h"

namespace placedb {
namespace {

// Comparison checks answered from a table of agreeing pairs; a place missing from it has no
// keypoints.
ComparisonCheck agreeing(const std::map<LocationId, int>& pairs) {
  return [pairs](LocationId c, int) -> std::optional<GeometricResult> {
    auto it = pairs.find(c);
    if (it == pairs.end()) return std::nullopt;
    GeometricResult g;
    g.inliers = it->second;
    g.matches = it->second + 10;
    return g;
  };
}

TEST(AgreeingPlace, ANeighbourThatAgreesOnMorePairsIsNamed) {
  const auto chosen = mostAgreeingPlace(10, {9, 10, 11}, agreeing({{9, 14}, {10, 20}, {11, 31}}));
  ASSERT_TRUE(chosen);
  EXPECT_EQ(chosen->location, 11);
  EXPECT_EQ(chosen->result.inliers, 31) << "the named place's own comparison";
}

TEST(AgreeingPlace, TheAcceptedPlaceStaysOnATieOrWhenItAgreesMost) {
  EXPECT_EQ(mostAgreeingPlace(10, {9, 11}, agreeing({{9, 20}, {10, 20}, {11, 19}}))->location, 10);
  EXPECT_EQ(mostAgreeingPlace(10, {9, 11}, agreeing({{9, 12}, {10, 25}, {11, 3}}))->location, 10);
}

TEST(AgreeingPlace, OfTwoNeighboursAsGoodTheFirstInOrder) {
  EXPECT_EQ(mostAgreeingPlace(10, {11, 9}, agreeing({{9, 30}, {10, 20}, {11, 30}}))->location, 11);
}

TEST(AgreeingPlace, PlacesWithoutKeypointsAreSkipped) {
  EXPECT_EQ(mostAgreeingPlace(10, {9, 11}, agreeing({{10, 20}, {11, 21}}))->location, 11);
  EXPECT_FALSE(mostAgreeingPlace(10, {9, 11}, agreeing({{9, 40}})))
      << "nothing to compare the neighbours with";
}

TEST(AgreeingPlace, EachNeighbourIsAskedToBeatTheBestSoFar) {
  std::vector<std::pair<LocationId, int>> asked;
  const auto table = agreeing({{9, 24}, {10, 20}, {11, 22}});
  const auto chosen = mostAgreeingPlace(10, {9, 11}, [&](LocationId c, int at_least) {
    asked.emplace_back(c, at_least);
    return table(c, at_least);
  });
  EXPECT_EQ(chosen->location, 9);
  const std::vector<std::pair<LocationId, int>> expected{{10, 0}, {9, 21}, {11, 25}};
  EXPECT_EQ(asked, expected) << "a check may spare the fit of a place that cannot win";
}

}  // namespace
}  // namespace placedb
