// The query's code search: centred codes (the part every place shares no longer counts) and
// a location ranked with its traversal neighbours.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "memory/place_index.h"
#include "memory/place_neighbourhood.h"

namespace placedb {
namespace {

const auto kAll = [](std::int64_t) { return true; };

// Codes of 4 values: a large part all share (the first), and each place's own.
PlaceIndex sharedTexture() {
  PlaceIndex index;
  index.add(1, {100, 10, 0, 0});
  index.add(2, {100, 0, 10, 0});
  index.add(3, {100, 0, 0, 10});
  index.add(4, {60, 0, 0, 60});  // least of the shared part, most of place 3's own
  return index;
}

TEST(PlaceIndexCentred, WhatEveryCodeSharesNoLongerCountsAsLikeness) {
  const PlaceIndex index = sharedTexture();
  const std::vector<std::int8_t> query{100, 0, 0, 30};  // place 3, seen again
  // The plain cosine prefers the shared part: 1 and 2 rank above 4.
  const auto plain = index.search(query, 4, kAll);
  EXPECT_EQ(plain[0].location, 3);
  EXPECT_NE(plain[1].location, 4);
  // Less the mean (90, 2.5, 2.5, 17.5), what is left of the query is place 3's own and 4's.
  const auto centred = index.centredSimilarities(query);
  ASSERT_EQ(centred.size(), 4u);
  EXPECT_GT(centred[index.rowOf(3)], centred[index.rowOf(1)]);
  EXPECT_GT(centred[index.rowOf(4)], centred[index.rowOf(1)]);
  EXPECT_GT(centred[index.rowOf(4)], centred[index.rowOf(2)]);
  EXPECT_LT(centred[index.rowOf(1)], 0.0);
  // Exact against the definition for one row.
  const double m[4] = {90, 2.5, 2.5, 17.5};
  const double q[4] = {100 - m[0], 0 - m[1], 0 - m[2], 30 - m[3]};
  const double x[4] = {60 - m[0], 0 - m[1], 0 - m[2], 60 - m[3]};
  double dot = 0, nq = 0, nx = 0;
  for (int d = 0; d < 4; ++d) {
    dot += q[d] * x[d];
    nq += q[d] * q[d];
    nx += x[d] * x[d];
  }
  EXPECT_NEAR(centred[index.rowOf(4)], dot / std::sqrt(nq * nx), 1e-9);
  EXPECT_EQ(index.rowOf(99), index.size());
}

TEST(PlaceIndexCentred, ReplacingACodeMovesTheMean) {
  PlaceIndex index = sharedTexture();
  const std::vector<std::int8_t> query{100, 0, 0, 30};
  const auto before = index.centredSimilarities(query);
  index.add(1, {0, 0, 0, 10});  // replaced: the mean follows
  const auto after = index.centredSimilarities(query);
  EXPECT_NE(before[index.rowOf(3)], after[index.rowOf(3)]);
  PlaceIndex fresh;
  fresh.add(1, {0, 0, 0, 10});
  fresh.add(2, {100, 0, 10, 0});
  fresh.add(3, {100, 0, 0, 10});
  fresh.add(4, {60, 0, 0, 60});
  EXPECT_EQ(fresh.centredSimilarities(query), after) << "as if it had been added so";
}

TEST(PlaceNeighbourhood, AStreetWhoseFramesAgreeBeatsALoneLookAlike) {
  PlaceIndex index;
  for (std::int64_t id = 1; id <= 6; ++id) index.add(id, {1, 0});
  // Two traversals, 1-2-3 and 4-5-6. Location 5 alone looks most like the query; 1, 2 and 3 a
  // little less, all three.
  const std::vector<double> likeness{0.5, 0.6, 0.5, 0.0, 0.9, 0.0};
  const PlaceNeighbourhood hood(index, {{1, 2}, {3, 2}, {4, 5}, {5, 6}, {2, 99}});
  const auto ranked = hood.search(likeness, 6, kAll);
  ASSERT_EQ(ranked.size(), 6u);
  // 1 and 3: (0.5 + 0.6) / 2, a tie the smaller id wins; 2: 1.6 / 3 (99 has no code and does
  // not count); 4 and 6: 0.45; 5: 0.3, last.
  EXPECT_EQ(ranked[0].location, 1);
  EXPECT_NEAR(ranked[0].similarity, 0.55, 1e-12);
  EXPECT_EQ(ranked[1].location, 3);
  EXPECT_EQ(ranked[2].location, 2);
  EXPECT_NEAR(ranked[2].similarity, 1.6 / 3, 1e-12);
  EXPECT_EQ(ranked[3].location, 4);
  EXPECT_EQ(ranked[5].location, 5);
  EXPECT_NEAR(ranked[5].similarity, 0.3, 1e-12);
  const auto no_one = hood.search(likeness, 1, [](std::int64_t id) { return id != 1; });
  EXPECT_EQ(no_one.front().location, 3);
  // Without links, each location is ranked alone.
  const PlaceNeighbourhood alone(index, {});
  EXPECT_EQ(alone.search(likeness, 1, kAll).front().location, 5);
  EXPECT_TRUE(alone.search({0.1}, 1, kAll).empty()) << "likeness of another index";
}

}  // namespace
}  // namespace placedb
