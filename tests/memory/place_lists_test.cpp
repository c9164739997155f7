// The place-code search through the inverted file (memory/place_lists.h): not engaged below its
// threshold, exact over the rows it probes, and the same answer whatever the order the codes came
// in and whenever the lists were trained, which is what makes a resumed run exact.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "memory/place_code.h"
#include "memory/place_index.h"

namespace placedb {
namespace {

constexpr std::size_t kDim = 256;

// Codes around `clusters` random centres, within the encoder's range: places of a few kinds.
std::vector<std::vector<std::int8_t>> clusteredCodes(std::size_t count, int clusters,
                                                     std::mt19937& rng) {
  std::uniform_int_distribution<int> byte(-100, 100), noise(-25, 25), pick(0, clusters - 1);
  std::vector<std::vector<int>> centres(clusters, std::vector<int>(kDim));
  for (auto& c : centres)
    for (int& v : c) v = byte(rng);
  std::vector<std::vector<std::int8_t>> codes(count, std::vector<std::int8_t>(kDim));
  for (auto& code : codes) {
    const auto& c = centres[pick(rng)];
    for (std::size_t d = 0; d < kDim; ++d)
      code[d] = static_cast<std::int8_t>(std::clamp(c[d] + noise(rng), -127, 127));
  }
  return codes;
}

std::vector<std::int8_t> nearCopy(const std::vector<std::int8_t>& code, std::mt19937& rng) {
  std::uniform_int_distribution<int> noise(-10, 10);
  std::vector<std::int8_t> out(code.size());
  for (std::size_t d = 0; d < code.size(); ++d)
    out[d] = static_cast<std::int8_t>(std::clamp(code[d] + noise(rng), -127, 127));
  return out;
}

const auto kEvery = [](std::int64_t) { return true; };

void expectSameMatches(const std::vector<PlaceMatch>& a, const std::vector<PlaceMatch>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].location, b[i].location) << "rank " << i;
    EXPECT_EQ(a[i].similarity, b[i].similarity) << "rank " << i;
  }
}

TEST(PlaceIndex, BelowListsFromEveryCodeIsScanned) {
  std::mt19937 rng(1);
  const auto codes = clusteredCodes(300, 8, rng);
  PlaceIndex exact, lists;
  lists.setListsFrom(301);
  for (std::size_t i = 0; i < codes.size(); ++i) {
    exact.add(std::int64_t(i + 1), codes[i]);
    lists.add(std::int64_t(i + 1), codes[i]);
  }
  for (int q = 0; q < 20; ++q) {
    const auto query = nearCopy(codes[std::size_t(q) * 13], rng);
    expectSameMatches(exact.search(query, 15, kEvery), lists.search(query, 15, kEvery));
  }
  EXPECT_EQ(lists.lists(), 0u);
}

TEST(PlaceIndex, ListsProbedAllAreTheExactScan) {
  std::mt19937 rng(2);
  const auto codes = clusteredCodes(2000, 16, rng);
  PlaceIndex exact, lists;
  lists.setListsFrom(1024, 64, /*probe_share=*/1);  // 16 lists, every one probed
  for (std::size_t i = 0; i < codes.size(); ++i) {
    exact.add(std::int64_t(i + 1), codes[i]);
    lists.add(std::int64_t(i + 1), codes[i]);
  }
  for (int q = 0; q < 30; ++q) {
    const auto query = nearCopy(codes[std::size_t(q) * 61], rng);
    const auto odd = [](std::int64_t id) { return id % 2 == 1; };
    expectSameMatches(exact.search(query, 15, odd), lists.search(query, 15, odd));
  }
  EXPECT_EQ(lists.lists(), 16u);
  EXPECT_EQ(lists.probes(), 16u);
}

TEST(PlaceIndex, ListsAnswerNeitherOnOrderNorOnWhenTrained) {
  std::mt19937 rng(3);
  const auto codes = clusteredCodes(3000, 40, rng);
  std::vector<std::vector<std::int8_t>> queries;
  for (int q = 0; q < 200; ++q) queries.push_back(nearCopy(codes[std::size_t(q) * 15], rng));

  // Trained by the first search past 1024 codes, then filled as the codes come.
  PlaceIndex grown;
  grown.setListsFrom(1024);
  for (std::size_t i = 0; i < codes.size(); ++i) {
    grown.add(std::int64_t(i + 1), codes[i]);
    if (i % 100 == 0) grown.search(queries[0], 5, kEvery);
  }
  // Every code first, in another order (a reopened map's), then trained.
  std::vector<std::size_t> order(codes.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::shuffle(order.begin(), order.end(), rng);
  PlaceIndex reopened;
  reopened.setListsFrom(1024);
  reopened.setThreads(2);
  for (std::size_t i : order) reopened.add(std::int64_t(i + 1), codes[i]);

  PlaceIndex exact;
  for (std::size_t i = 0; i < codes.size(); ++i) exact.add(std::int64_t(i + 1), codes[i]);

  std::size_t same_best = 0;
  for (const auto& query : queries) {
    const auto g = grown.search(query, 5, kEvery);
    expectSameMatches(g, reopened.search(query, 5, kEvery));
    const auto e = exact.search(query, 5, kEvery);
    same_best += !g.empty() && g[0].location == e[0].location;
  }
  EXPECT_EQ(grown.lists(), 16u);
  EXPECT_EQ(grown.probes(), 1u);
  // One list in 16 probed, and still the place nearest a near copy of a code is found.
  EXPECT_GE(same_best, 190u);
}

}  // namespace
}  // namespace placedb
