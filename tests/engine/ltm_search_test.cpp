// Long-term memory that can be searched: place codes find locations whose words left RAM, during
// mapping (they come back to WM before the filter runs) and in localisation (query answers from
// every tier, with a verdict).
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <iterator>

#include <opencv2/imgproc.hpp>

#include "engine_fixture.h"
#include "file_bytes.h"
#include "memory/place_code.h"
#include "memory/place_index.h"

namespace placedb::testing {
namespace {

class LtmSearchTest : public SamplesMapTest {
 protected:
  // Maps the first `frames` frames with a small working memory, so that the early places end
  // in LTM.
  void mapFirst(std::size_t frames, const Options& options) {
    auto map = Map::open(path_.string(), options);
    map->beginSession("first part");
    for (std::size_t i = 0; i < frames; ++i) map->process(seq_->images[i], i, seq_->paths[i]);
  }
  static bool covers(const QueryMatch& m, std::int64_t frame, std::int64_t tolerance) {
    for (const auto& f : m.frames)
      if (std::llabs(f.source_index - frame) <= tolerance) return true;
    return false;
  }
};

TEST_F(LtmSearchTest, QueryFindsPlacesThatMovedToLongTermMemory) {
  Options options;
  options.wm_max = 7;
  mapFirst(44, options);
  ASSERT_GE(sqlCount(path_, "SELECT count(*) FROM locations WHERE tier = 2"), 10);
  const std::string before = readBytes(path_);

  auto map = Map::open(path_.string(), options, Map::Mode::kLocalisation);
  std::size_t found = 0, found_in_ltm = 0, asked = 0;
  for (std::size_t i = 44; i < 80; i += 3) {  // revisits of frames i - 40
    const QueryResult q = map->query(seq_->images[i], 3);
    ++asked;
    ASSERT_FALSE(q.matches.empty());
    EXPECT_GE(q.searched, 30u) << "every tier is searched";
    const QueryMatch& best = q.matches.front();
    if (q.verdict == QueryVerdict::kKnown && covers(best, static_cast<std::int64_t>(i) - 40, 3)) {
      ++found;
      if (best.tier == Tier::kLtm) ++found_in_ltm;
    }
  }
  EXPECT_GE(found, asked - 2) << "the revisited place is the best match, verified";
  EXPECT_GE(found_in_ltm, 3u) << "places in LTM are found too (before, only STM and WM were); "
                              << found << " of " << asked << " found";
  map.reset();
  EXPECT_EQ(readBytes(path_), before) << "localisation must leave the map byte-identical";
}

TEST_F(LtmSearchTest, QueryFindsLtmPlacesByTheirOwnWords) {
  Options options;
  options.wm_max = 8;
  mapFirst(44, options);
  const std::string before = readBytes(path_);

  // The mapping dropped the words of these places from RAM; a query takes them back, so the frame
  // whose words an LTM place holds (its first: frames merged into it later only resemble it)
  // shares them with it (eq. 5 of 0.86-0.98 here, 0.17-0.37 when the query only had the words of
  // WM) and the word search ranks it.
  auto map = Map::open(path_.string(), options, Map::Mode::kLocalisation);
  std::size_t asked = 0, by_words = 0;
  for (std::size_t i = 0; i < 44; ++i) {
    const QueryResult q = map->query(seq_->images[i], 3);
    if (q.matches.empty()) continue;  // a frame without features
    const QueryMatch& best = q.matches.front();
    if (best.tier != Tier::kLtm || best.frames.empty() ||
        best.frames.front().source_index != static_cast<std::int64_t>(i))
      continue;
    ++asked;
    if (best.similarity > 0.5) ++by_words;
  }
  EXPECT_GE(asked, 8u) << "frames of LTM places answered with their own location";
  EXPECT_EQ(by_words, asked) << "their words were searched, not only their codes";
  map.reset();
  EXPECT_EQ(readBytes(path_), before) << "localisation must leave the map byte-identical";
}

TEST_F(LtmSearchTest, AnImageOfNoStoredPlaceIsUnknown) {
  mapFirst(40, Options());
  auto map = Map::open(path_.string(), Options(), Map::Mode::kLocalisation);
  // Textured but of no place: blurred noise has features and look-alike words, no shared scene.
  cv::Mat noise(384, 512, CV_8UC1);
  cv::RNG rng(7);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 255);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 2.0);
  const QueryResult q = map->query(noise, 3);
  EXPECT_GT(q.feature_count, 20u);
  EXPECT_EQ(q.verdict, QueryVerdict::kUnknown);
  for (const auto& m : q.matches) EXPECT_FALSE(m.verified);
  // And a frame of the map itself is known.
  EXPECT_EQ(map->query(seq_->images[20], 3).verdict, QueryVerdict::kKnown);
}

TEST_F(LtmSearchTest, MappingBringsSearchedPlacesBackBeforeTheFilter) {
  Options options;
  options.wm_max = 8;
  auto map = Map::open(path_.string(), options);
  map->beginSession("all");
  std::size_t found = 0, accepted_on_found = 0;
  for (std::size_t i = 0; i < seq_->images.size(); ++i) {
    const FrameResult r = map->process(seq_->images[i], i, seq_->paths[i]);
    found += r.retrieved_by_search;
    if (r.retrieved_by_search > 0 && r.hypothesis.accepted) ++accepted_on_found;
    EXPECT_EQ(impl(*map).checkConsistency(), "") << "after frame " << i;
  }
  EXPECT_GT(found, 5u);
  EXPECT_GT(accepted_on_found, 0u) << "a place found in LTM closes a loop in the same frame";
  map.reset();
  // Every location has its code in the file, whatever its tier.
  EXPECT_EQ(sqlCount(path_, "SELECT count(*) FROM locations"),
            sqlCount(path_, "SELECT count(*) FROM place_codes"));
}

TEST(PlaceCodes, SameImageCodesAlikeOtherImagesLess) {
  cv::RNG rng(3);
  cv::Mat a(300, 64, CV_32F), b(300, 64, CV_32F), training(300, 64, CV_32F);
  rng.fill(a, cv::RNG::NORMAL, 0, 1);
  rng.fill(b, cv::RNG::NORMAL, 0, 1);
  rng.fill(training, cv::RNG::NORMAL, 0, 1);
  // Not trained on `a`: residuals of the very points k-means averaged sum to nothing.
  const PlaceCoder coder = PlaceCoder::train(training, PlaceCodeSettings());
  cv::Mat a_noisy = a.clone();
  cv::Mat noise(a.size(), CV_32F);
  rng.fill(noise, cv::RNG::NORMAL, 0, 0.1);
  a_noisy += noise;
  const auto ca = coder.encode(a), cn = coder.encode(a_noisy), cb = coder.encode(b);
  EXPECT_GT(codeSimilarity(ca.data(), cn.data(), coder.codeDim()), 0.8);
  EXPECT_LT(codeSimilarity(ca.data(), cb.data(), coder.codeDim()), 0.5);
  // Serialised centres make the same codes.
  const PlaceCoder again = PlaceCoder::fromBytes(coder.toBytes(), 64);
  EXPECT_EQ(again.encode(a), ca);
  EXPECT_THROW(PlaceCoder::fromBytes(coder.toBytes(), 128), Error);
}

TEST(PlaceCodes, CodesAreTheOnesStoredMapsHold) {
  // Maps store every location's code and compare new frames' codes with them: encode() must
  // give the same bytes as the coder that wrote them. The hash is that of the codes of the
  // straightforward projection (one output at a time, its inputs in order).
  cv::RNG rng(5);
  cv::Mat training(300, 64, CV_32F);
  rng.fill(training, cv::RNG::UNIFORM, -1.0, 1.0);
  const PlaceCoder coder = PlaceCoder::train(training, PlaceCodeSettings());
  std::uint64_t hash = 1469598103934665603ull;  // FNV-1a over every code's bytes
  for (int f = 0; f < 20; ++f) {
    cv::Mat descriptors(40 + f * 7, 64, CV_32F);
    rng.fill(descriptors, cv::RNG::UNIFORM, -1.0, 1.0);
    for (std::int8_t b : coder.encode(descriptors))
      hash = (hash ^ static_cast<std::uint8_t>(b)) * 1099511628211ull;
  }
  EXPECT_EQ(hash, 12060841445019307796ull);
}

TEST(PlaceCodes, IndexRanksByCosineWithIdsBreakingTies) {
  PlaceIndex index;
  index.add(5, {1, 0, 0});
  index.add(3, {1, 0, 0});
  index.add(9, {0, 1, 0});
  index.add(7, {1, 1, 0});
  const auto all = index.search({1, 0, 0}, 3, [](std::int64_t) { return true; });
  ASSERT_EQ(all.size(), 3u);
  EXPECT_EQ(all[0].location, 3);
  EXPECT_EQ(all[1].location, 5);
  EXPECT_EQ(all[2].location, 7);
  const auto odd_only = index.search({0, 1, 0}, 1, [](std::int64_t id) { return id != 9; });
  EXPECT_EQ(odd_only.front().location, 7);
  EXPECT_NEAR(index.similarity({1, 0, 0}, 7), 1 / std::sqrt(2.0), 1e-9);
  EXPECT_THROW(index.add(1, {1, 2}), Error);
}

}  // namespace
}  // namespace placedb::testing
