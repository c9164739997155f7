// Whether a closure is what the frame's agreement singles out: where the frame's surroundings and
// the place's end along the way here, which places of the way are compared, and when one of them
// refutes the closure (decision/way_here.h).
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "decision/way_here.h"

namespace placedb {
namespace {

// A way whose places are unrelated to the frame where `pattern` has a '.', related at '#'
// (index 0, the newest place, first). Records which places were asked about.
struct Way {
  explicit Way(std::string p) : pattern(std::move(p)) {}
  std::string pattern;
  std::set<std::size_t> asked;
  Unrelated unrelated() {
    return [this](std::size_t i) {
      asked.insert(i);
      return pattern.at(i) == '.';
    };
  }
};

TEST(WayHere, TheFramesSurroundingsEndAtTwoUnrelatedPlacesInARow) {
  Way way("##.#..#...##");
  EXPECT_EQ(surroundingsEnd(way.pattern.size(), way.unrelated()), 4u)
      << "a single place without agreement (a blurred view) does not end them";
  EXPECT_EQ(way.asked.count(11), 0u) << "the walk stops where they end";
}

TEST(WayHere, AFrameThatAgreesWithItsWholeWayNeverLeft) {
  Way all("#######");
  EXPECT_EQ(surroundingsEnd(all.pattern.size(), all.unrelated()), 7u);
  Way one_gap("###.###");
  EXPECT_EQ(surroundingsEnd(one_gap.pattern.size(), one_gap.unrelated()), 7u);
  Way last("######.");
  EXPECT_EQ(surroundingsEnd(last.pattern.size(), last.unrelated()), 7u)
      << "one unrelated place beside the accepted one is not leaving either";
  EXPECT_EQ(surroundingsEnd(0, all.unrelated()), 0u);
}

TEST(WayHere, ThePlacesSurroundingsBeginWhereTwoInARowFailFromTheFarEnd) {
  //               0123456789
  Way way("##..#...##");
  const std::size_t end = surroundingsEnd(way.pattern.size(), way.unrelated());
  ASSERT_EQ(end, 2u);
  EXPECT_EQ(placeSurroundingsBegin(way.pattern.size(), end, way.unrelated()), 7u)
      << "8 and 9 are the approach to the place, seen again";
  Way none("##..######");
  EXPECT_EQ(placeSurroundingsBegin(none.pattern.size(), 2, none.unrelated()), 3u)
      << "nothing between the two surroundings but the place where the frame's end";
}

TEST(WayHere, TheMostSimilarPlacesComeFirstTiesToTheNewer) {
  const std::vector<LocationSimilarity> similarities = {{3, 0.2, 1}, {5, 0.7, 1}, {8, 0.2, 1}};
  EXPECT_EQ(mostSimilar({3, 4, 5, 8}, similarities, 3), (std::vector<LocationId>{5, 8, 3}));
  EXPECT_EQ(mostSimilar({3, 4, 5, 8}, similarities, 10), (std::vector<LocationId>{5, 8, 3, 4}))
      << "a place without a similarity ranks last";
  EXPECT_TRUE(mostSimilar({3, 4}, similarities, 0).empty());
}

TEST(WayHere, TheMoreSimilarAnImpostorTheLessItIsCounted) {
  EXPECT_EQ(impostorTries(1, 0), 2);
  EXPECT_EQ(impostorTries(2, 0), 6);
  EXPECT_EQ(impostorTries(8, 0), 72);
  double weights = 0;
  for (int j = 1; j <= 1000; ++j) weights += 1 / impostorTries(j, 0);
  EXPECT_LT(weights, 1) << "however many are compared, at most one false alarm in all";
  EXPECT_EQ(impostorTries(1, 4), 4) << "sessions begun before: every one alike";
  EXPECT_EQ(impostorTries(3, 4), 4);
}

TEST(WayHere, AnImpostorAtChanceLevelRefutesNothing) {
  // A closure accepted at the frame's bar (NFA 1e-3) stands against places of the way that agree
  // no better than chance, however many were compared.
  EXPECT_FALSE(refutes(-3.0, 0.0, 2, 1e-3));
  EXPECT_FALSE(refutes(-3.0, 2.5, 6, 1e-3));
  EXPECT_FALSE(refutes(-3.0, -0.5, 6, 1e-3)) << "1e-0.5 as the second is chance: 6 x 0.32 > 1";
}

TEST(WayHere, AnImpostorAsStrongAsThePlaceRefutesIt) {
  EXPECT_TRUE(refutes(-5.0, -5.0, 1, 1e-3));
  EXPECT_TRUE(refutes(-11.0, -9.7, 4, 1e-3)) << "1e-11 is not 1e3 x stronger than 4 x 1e-9.7";
  EXPECT_TRUE(refutes(-4.0, -1.5, 2, 1e-3)) << "the bar is now 1e-3 below the impostor";
  EXPECT_FALSE(refutes(-4.0, -1.5, 100, 1e-3)) << "... counted as the false alarms it stands for";
}

TEST(WayHere, AnImpostorThatPassesTheBarItselfRefutesAlone) {
  // A corridor at 160x120: the frame agrees with a place five door pitches back at 1e-15.2 and
  // with one a pitch back at 1e-9.7. Both are the same picture; the second is known to be another
  // place, so the first is no more singled out than it.
  EXPECT_TRUE(refutes(-15.2, -9.7, 2, 1e-3));
  EXPECT_TRUE(refutes(-25.2, -6.5, 72, 1e-3)) << "72 x 1e-6.5 still passes 1e-3";
  EXPECT_FALSE(refutes(-25.2, -4.5, 72, 1e-3)) << "72 x 1e-4.5 does not, and is far weaker";
  EXPECT_FALSE(refutes(-15.2, -9.7, 4, 1e-3, false))
      << "sessions begun before: only an impostor near the place's own strength refutes";
}

}  // namespace
}  // namespace placedb
