// The WM keypoint cache hands back what was put in and forgets locations that leave WM; the
// positions of a place brought back are handed over once, to its first load.
#include <gtest/gtest.h>

#include "geometry/keypoint_cache.h"

namespace placedb {
namespace {

CachedKeypoints entry(float x) {
  CachedKeypoints e;
  e.points = {{x, 1.f}};
  e.words = {7};
  auto codes = std::make_shared<DescriptorCodes>();
  codes->rows = 3;
  e.codes = codes;
  return e;
}

TEST(KeypointCache, FindsWhatWasInserted) {
  KeypointCache cache;
  EXPECT_EQ(cache.find(4), nullptr);
  const CachedKeypoints& stored = cache.insert(4, entry(2.f));
  EXPECT_EQ(stored.points[0].x, 2.f);
  ASSERT_NE(cache.find(4), nullptr);
  ASSERT_NE(cache.find(4)->codes, nullptr);
  EXPECT_EQ(cache.find(4)->codes->rows, 3);
}

TEST(KeypointCache, RetainIfDropsLocationsThatLeft) {
  KeypointCache cache;
  for (std::int64_t id = 1; id <= 6; ++id) cache.insert(id, entry(static_cast<float>(id)));
  cache.retainIf([](std::int64_t id) { return id % 2 == 0; });
  EXPECT_EQ(cache.size(), 3u);
  EXPECT_EQ(cache.find(1), nullptr);
  ASSERT_NE(cache.find(4), nullptr);
  EXPECT_EQ(cache.find(4)->points[0].x, 4.f);
}

TEST(KeypointCache, KeptPositionsAreTakenOnceAndLeaveWithTheirPlace) {
  KeypointCache cache;
  EXPECT_FALSE(cache.takePositions(3));
  cache.keepPositions(3, entry(3.f));
  cache.keepPositions(5, entry(5.f));
  EXPECT_EQ(cache.find(3), nullptr);  // positions are not an entry: its descriptors are unread
  const auto taken = cache.takePositions(3);
  ASSERT_TRUE(taken);
  EXPECT_EQ(taken->points[0].x, 3.f);
  EXPECT_EQ(taken->words, std::vector<std::int64_t>{7});
  EXPECT_FALSE(cache.takePositions(3));
  cache.retainIf([](std::int64_t id) { return id != 5; });
  EXPECT_FALSE(cache.takePositions(5));
  EXPECT_EQ(cache.positionsKept(), 0u);
}

TEST(KeypointCache, PositionsOfAPlaceAlreadyLoadedAreNotKept) {
  KeypointCache cache;
  cache.insert(4, entry(4.f));
  cache.keepPositions(4, entry(9.f));
  EXPECT_EQ(cache.positionsKept(), 0u);
  EXPECT_EQ(cache.find(4)->points[0].x, 4.f);
}

}  // namespace
}  // namespace placedb
