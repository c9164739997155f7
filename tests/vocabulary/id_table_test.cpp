// Word id -> slot: the same answers as an ordered map through any sequence of changes, and RAM
// that follows the ids present, not the range they spread over.
#include <map>
#include <random>

#include <gtest/gtest.h>

#include "vocabulary/id_table.h"

namespace placedb::vocab {
namespace {

void expectSame(const IdTable& table, const std::map<std::int64_t, std::uint32_t>& expected) {
  ASSERT_EQ(table.size(), expected.size());
  std::vector<std::int64_t> ids;
  for (const auto& [id, slot] : expected) {
    ids.push_back(id);
    ASSERT_EQ(table.find(id), slot) << "id " << id;
  }
  EXPECT_EQ(table.ids(), ids);
}

// Pages fill past the dense line and empty below the sparse one, again and again.
TEST(IdTable, AgreesWithAnOrderedMapThroughEveryChange) {
  std::mt19937_64 rng(3);
  IdTable table;
  std::map<std::int64_t, std::uint32_t> expected;
  for (int round = 0; round < 6; ++round) {
    const bool filling = round % 2 == 0;
    for (int step = 0; step < 6000; ++step) {
      // Mostly one page, some ids far away.
      const std::int64_t id =
          step % 10 == 0 ? std::int64_t(rng() % 1000000) : 8192 + std::int64_t(rng() % 4096);
      const auto slot = static_cast<std::uint32_t>(rng() % 100000);
      if (filling && !expected.count(id)) {
        table.set(id, slot);
        expected[id] = slot;
      } else if (!filling && expected.count(id)) {
        table.erase(id);
        expected.erase(id);
      }
      EXPECT_EQ(table.find(id), expected.count(id) ? expected[id] : IdTable::kNone);
    }
    expectSame(table, expected);
  }
  for (const auto& [id, slot] : std::map<std::int64_t, std::uint32_t>(expected)) {
    table.erase(id);
    expected.erase(id);
  }
  expectSame(table, expected);
  EXPECT_EQ(table.heldBytes(), 0u);
}

// Working memory after places came back from long-term memory: its words' ids spread over the
// map's whole history.
TEST(IdTable, ScatteredIdsTakeRoomForThemselvesOnly) {
  IdTable table;
  for (std::uint32_t i = 0; i < 1000; ++i) table.set(std::int64_t{i} * 4001, i);
  EXPECT_LT(table.heldBytes(), 1000u * 16);  // 4 bytes for each of 4M ids would be 16 MB
  for (std::uint32_t i = 0; i < 1000; ++i) ASSERT_EQ(table.find(std::int64_t{i} * 4001), i);
  // A run of new words: one dense page.
  for (std::uint32_t i = 0; i < 4096; ++i) table.set(std::int64_t{1} << 32 | i, i);
  EXPECT_LT(table.heldBytes(), 1000u * 16 + 4096 * 4 + 64);
}

}  // namespace
}  // namespace placedb::vocab
