// The place-code scan must give what comparing every code in full gives: the same products, the
// same k best in the same order (ties by id), whatever the values and across block boundaries.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "memory/place_code.h"
#include "memory/place_index.h"

namespace placedb {
namespace {

// Bytes from `lowest`: -127 gives codes as the encoder makes them, -128 any byte at all.
std::vector<std::int8_t> randomCode(std::size_t dim, std::mt19937& rng, int lowest = -128) {
  std::uniform_int_distribution<int> byte(lowest, 127);
  std::vector<std::int8_t> code(dim);
  for (auto& v : code) v = static_cast<std::int8_t>(byte(rng));
  return code;
}

// The definition: every code's cosine, best first, smaller id first on ties.
std::vector<PlaceMatch> everyCode(const std::vector<std::vector<std::int8_t>>& codes,
                                  const std::vector<std::int8_t>& query, std::size_t k,
                                  std::int64_t refused) {
  const std::size_t dim = query.size();
  const double qn = std::sqrt(double(codeDot(query.data(), query.data(), dim)));
  std::vector<PlaceMatch> all;
  for (std::size_t i = 0; i < codes.size(); ++i) {
    const double n = std::sqrt(double(codeDot(codes[i].data(), codes[i].data(), dim)));
    if (n == 0 || static_cast<std::int64_t>(i + 1) == refused) continue;
    all.push_back({static_cast<std::int64_t>(i + 1),
                   double(codeDot(codes[i].data(), query.data(), dim)) / (n * qn)});
  }
  std::sort(all.begin(), all.end(), [](const PlaceMatch& a, const PlaceMatch& b) {
    return a.similarity != b.similarity ? a.similarity > b.similarity : a.location < b.location;
  });
  if (all.size() > k) all.resize(k);
  return all;
}

TEST(PlaceIndex, CodeDotsAreEachCodesDot) {
  std::mt19937 rng(1);
  for (std::size_t dim : {256, 48, 37}) {
    const auto query = randomCode(dim, rng);
    std::vector<std::int8_t> codes;
    for (int r = 0; r < 9; ++r) {
      const auto c = randomCode(dim, rng);
      codes.insert(codes.end(), c.begin(), c.end());
    }
    std::fill(codes.begin(), codes.begin() + std::ptrdiff_t(dim), std::int8_t(-128));  // extremes
    std::vector<std::int32_t> out(9);
    codeDots(query.data(), codes.data(), 9, dim, out.data());
    for (std::size_t r = 0; r < 9; ++r)
      EXPECT_EQ(out[r], codeDot(query.data(), codes.data() + r * dim, dim)) << dim << " row " << r;
  }
}

TEST(PlaceIndex, EncodedCodeDotsAreEachCodesDot) {
  std::mt19937 rng(3);
  for (std::size_t dim : {256, 64, 32, 48}) {
    for (std::size_t rows : {1, 4, 9}) {  // whole groups of four rows and a tail
      const auto query = randomCode(dim, rng, -127);
      std::vector<std::int8_t> codes;
      for (std::size_t r = 0; r < rows; ++r) {
        const auto c = randomCode(dim, rng, -127);
        codes.insert(codes.end(), c.begin(), c.end());
      }
      // The extremes: every pair of products at 2 x 127^2, of either sign.
      for (std::size_t d = 0; d < dim; ++d) codes[d] = query[d] < 0 ? -127 : 127;
      ASSERT_TRUE(withinEncodedRange(codes.data(), codes.size()));
      std::vector<std::int32_t> out(rows);
      encodedCodeDots(query.data(), codes.data(), rows, dim, out.data());
      for (std::size_t r = 0; r < rows; ++r)
        EXPECT_EQ(out[r], codeDot(query.data(), codes.data() + r * dim, dim))
            << dim << " row " << r << " of " << rows;
    }
  }
  const std::vector<std::int8_t> lowest(32, -128);
  EXPECT_FALSE(withinEncodedRange(lowest.data(), lowest.size()));
}

void expectSearchIsExact(const PlaceIndex& index,
                         const std::vector<std::vector<std::int8_t>>& codes,
                         const std::vector<std::int8_t>& query, const std::string& what) {
  for (std::size_t k : {1, 5, 15}) {
    const std::int64_t refused = 114;
    const auto got = index.search(query, k, [](std::int64_t id) { return id != refused; });
    const auto want = everyCode(codes, query, k, refused);
    ASSERT_EQ(got.size(), want.size()) << what;
    for (std::size_t i = 0; i < got.size(); ++i) {
      EXPECT_EQ(got[i].location, want[i].location) << what << " k " << k;
      EXPECT_EQ(got[i].similarity, want[i].similarity) << what << " k " << k;
    }
  }
}

// The scan takes the cheaper multiply only while no code holds -128; replacing codes must keep
// that count right, on one thread and on several.
TEST(PlaceIndex, SearchIsExactAsCodesComeAndGoOutOfTheEncodedRange) {
  std::mt19937 rng(4);
  const std::size_t dim = 256;
  for (int threads : {1, 2, 3}) {
    std::vector<std::vector<std::int8_t>> codes;
    PlaceIndex index;
    index.setThreads(threads);
    for (int i = 0; i < 5000; ++i) {  // several blocks of rows and a partial one
      codes.push_back(randomCode(dim, rng, -127));
      index.add(i + 1, codes.back());
    }
    const std::string on = std::to_string(threads) + " threads";
    std::vector<std::int8_t> query = codes[4321];
    query[0] = -100;        // the code's nearest query, negative where the code is -128
    codes[4321][0] = -128;  // the one byte the cheaper multiply gets wrong against q < 0
    index.add(4322, codes[4321]);
    expectSearchIsExact(index, codes, query, on + ", one code holds -128");
    codes[4321][0] = -127;
    index.add(4322, codes[4321]);
    expectSearchIsExact(index, codes, query, on + ", every code in range again");
    expectSearchIsExact(index, codes, randomCode(dim, rng, -127), on + ", a random query");
    query[7] = -128;
    expectSearchIsExact(index, codes, query, on + ", a query holding -128");
  }
}

TEST(PlaceIndex, SearchFindsWhatComparingEveryCodeFinds) {
  std::mt19937 rng(2);
  const std::size_t dim = 256;
  std::vector<std::vector<std::int8_t>> codes;
  PlaceIndex index;
  for (int i = 0; i < 2500; ++i) {  // more than one block of rows
    std::vector<std::int8_t> code = randomCode(dim, rng);
    if (i % 97 == 5) code = codes[static_cast<std::size_t>(i / 2)];  // exact ties
    if (i == 700) code.assign(dim, 0);                               // no code
    codes.push_back(code);
    index.add(i + 1, code);
  }
  for (int trial = 0; trial < 20; ++trial) {
    // Queries near stored codes, so that the k best stand out, and plain random ones.
    std::vector<std::int8_t> query = codes[static_cast<std::size_t>(trial * 113)];
    if (trial % 2) query = randomCode(dim, rng);
    for (std::size_t k : {1, 5, 15}) {
      const std::int64_t refused = trial * 113 + 1;
      const auto got = index.search(query, k, [refused](std::int64_t id) { return id != refused; });
      const auto want = everyCode(codes, query, k, refused);
      ASSERT_EQ(got.size(), want.size());
      for (std::size_t i = 0; i < got.size(); ++i) {
        EXPECT_EQ(got[i].location, want[i].location) << "trial " << trial << " k " << k;
        EXPECT_EQ(got[i].similarity, want[i].similarity);
      }
    }
  }
}

}  // namespace
}  // namespace placedb
