// Location id -> value, kept flat in pages: any ids, visited in ascending order.
#include <map>
#include <random>

#include <gtest/gtest.h>

#include "memory/location_table.h"

namespace placedb {
namespace {

TEST(LocationTable, AgreesWithAnOrderedMap) {
  std::mt19937_64 rng(5);
  LocationTable<std::int64_t> table;
  std::map<std::int64_t, std::int64_t> expected;
  for (int step = 0; step < 20000; ++step) {
    // Dense ids near zero (negative ones too), and some far apart.
    const std::int64_t id = step % 7 == 0 ? std::int64_t(rng() >> 4) - (std::int64_t{1} << 58)
                                          : std::int64_t(rng() % 5000) - 100;
    if (expected.count(id)) {
      ASSERT_EQ(*table.find(id), expected[id]);
      if (rng() % 2) {
        table.erase(id);
        expected.erase(id);
      } else {
        *table.find(id) += 1;
        expected[id] += 1;
      }
    } else {
      ASSERT_FALSE(table.contains(id));
      table.insert(id, step);
      expected[id] = step;
    }
  }
  ASSERT_EQ(table.size(), expected.size());
  auto next = expected.begin();
  table.forEach([&](std::int64_t id, std::int64_t value) {
    ASSERT_NE(next, expected.end());
    EXPECT_EQ(id, next->first);
    EXPECT_EQ(value, next->second);
    ++next;
  });
  EXPECT_EQ(next, expected.end());
}

}  // namespace
}  // namespace placedb
