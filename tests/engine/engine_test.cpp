// The pipeline's behaviour through the public API: merging, bad frames, sessions, localisation.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <map>
#include <sstream>

#include "engine_fixture.h"
#include "file_bytes.h"

namespace placedb::testing {
namespace {

class EngineTest : public SamplesMapTest {};

TEST_F(EngineTest, SameImageTwiceMergesIntoOneLocation) {
  auto map = Map::open(path_.string(), Options());
  map->beginSession("repeat");
  auto first = map->process(seq_->images[0], 0, "a");
  auto second = map->process(seq_->images[0], 1, "a");
  auto third = map->process(seq_->images[0], 2, "a");
  EXPECT_EQ(first.outcome, FrameOutcome::kNewLocation);
  EXPECT_EQ(second.outcome, FrameOutcome::kMerged);
  EXPECT_EQ(third.outcome, FrameOutcome::kMerged);
  EXPECT_EQ(second.location_id, first.location_id);
  EXPECT_EQ(second.words_created, 0u) << "an identical image finds all its words";
  EXPECT_EQ(impl(*map).checkConsistency(), "");
  map->close();
  EXPECT_EQ(sqlCount(path_, "SELECT weight FROM locations"), 2);
  EXPECT_EQ(sqlCount(path_, "SELECT count(*) FROM location_frames"), 3);
  EXPECT_EQ(sqlCount(path_, "SELECT count(*) FROM frames WHERE outcome = 1"), 2);
}

TEST_F(EngineTest, FeaturelessImageIsABadFrameAndNoLocation) {
  auto map = Map::open(path_.string(), Options());
  map->beginSession("bad");
  map->process(seq_->images[0], 0, "a");
  auto blank = map->process(cv::Mat(384, 512, CV_8UC1, cv::Scalar(128)), 1, "blank");
  auto tiny = map->process(cv::Mat(4, 4, CV_8UC1, cv::Scalar(0)), 2, "tiny");
  auto unreadable = map->recordUnreadable(3, "missing.png");
  for (const auto& r : {blank, tiny, unreadable}) {
    EXPECT_EQ(r.outcome, FrameOutcome::kBad);
    EXPECT_EQ(r.location_id, 0);
    EXPECT_EQ(r.hypothesis.location_id, 0);
  }
  map->close();
  EXPECT_EQ(sqlCount(path_, "SELECT count(*) FROM frames"), 4);
  EXPECT_EQ(sqlCount(path_, "SELECT count(*) FROM frames WHERE outcome = 2"), 3);
  EXPECT_EQ(sqlCount(path_, "SELECT count(*) FROM locations"), 1);
}

// Every frame row holds the time of its own writes, and the total includes it.
TEST_F(EngineTest, FramesStoreTheirStorageTime) {
  auto map = Map::open(path_.string(), Options());
  map->beginSession("timed");
  for (int i = 0; i < 4; ++i) map->process(seq_->images[static_cast<std::size_t>(i)], i, "a");
  map->recordUnreadable(4, "missing.png");
  map->close();
  EXPECT_EQ(sqlCount(path_, "SELECT count(*) FROM frames"), 5);
  EXPECT_EQ(sqlCount(path_, "SELECT count(*) FROM frames WHERE storage_ms > 0"), 5);
  EXPECT_EQ(sqlCount(path_,
                     "SELECT count(*) FROM frames WHERE abs(total_ms - (features_ms + "
                     "quantisation_ms + likelihood_ms + filter_ms + memory_ms + storage_ms)) "
                     "> 1e-6"),
            0);
}

TEST_F(EngineTest, LoopClosuresLinkRevisitsAndSettingsAreStored) {
  // Ground truth: lines "q r", frame q revisits frame r.
  std::map<std::int64_t, std::vector<std::int64_t>> truth;
  std::ifstream gt(dataset("rtabmap_samples") / "gt_pairs.txt");
  std::string line;
  while (std::getline(gt, line)) {
    std::istringstream fields(line);
    std::int64_t q, r;
    if (line[0] != '#' && fields >> q >> r) truth[q].push_back(r);
  }
  Options options;
  options.t_sim = 0.25;
  auto map = Map::open(path_.string(), options);
  map->beginSession("samples");
  std::size_t accepted = 0, right = 0;
  for (std::size_t i = 0; i < seq_->images.size(); ++i) {
    auto r = map->process(seq_->images[i], i, seq_->paths[i]);
    if (!r.hypothesis.accepted) continue;
    ++accepted;
    bool ok = false;
    for (const auto& f : r.hypothesis.frames)
      for (std::int64_t ref : truth[static_cast<std::int64_t>(i)])
        ok = ok || std::llabs(f.source_index - ref) <= 10;
    right += ok;
  }
  map->close();
  EXPECT_GT(accepted, 20u);
  EXPECT_EQ(right, accepted) << "every accepted loop closure is within 10 frames of the truth";
  // Each accepted hypothesis is a loop-closure link between the frame's location and it.
  EXPECT_EQ(sqlCount(path_,
                     "SELECT count(*) FROM hypotheses h JOIN frames f ON f.id = h.frame_id "
                     "WHERE h.accepted = 1 AND h.best_location_id <> f.location_id AND NOT EXISTS "
                     "(SELECT 1 FROM links k WHERE k.type = 1 AND "
                     "k.location_a = min(f.location_id, h.best_location_id) AND "
                     "k.location_b = max(f.location_id, h.best_location_id))"),
            0);
  EXPECT_GT(sqlCount(path_, "SELECT count(*) FROM links WHERE type = 1"), 20);
  EXPECT_EQ(sqlCount(path_, "SELECT count(*) FROM settings WHERE key = 't_sim' AND value = '0.25'"),
            1);
  EXPECT_EQ(sqlCount(path_, "SELECT clean_close FROM sessions"), 1);
}

TEST_F(EngineTest, SecondSessionClosesLoopsWithTheFirst) {
  {
    auto map = Map::open(path_.string(), Options());
    map->beginSession("first half");
    for (std::size_t i = 0; i < 40; ++i) map->process(seq_->images[i], i, seq_->paths[i]);
  }
  auto map = Map::open(path_.string(), Options());
  auto session = map->beginSession("second half");
  EXPECT_EQ(map->sessions().size(), 2u);
  std::size_t cross = 0;
  for (std::size_t i = 40; i < seq_->images.size(); ++i) {
    auto r = map->process(seq_->images[i], i - 40, seq_->paths[i]);
    if (r.hypothesis.accepted && !r.hypothesis.frames.empty() &&
        r.hypothesis.frames.front().session_id != session.id)
      ++cross;
  }
  map->close();
  EXPECT_GT(cross, 10u);
  EXPECT_GT(sqlCount(path_,
                     "SELECT count(*) FROM links k JOIN locations a ON a.id = k.location_a "
                     "JOIN locations b ON b.id = k.location_b "
                     "WHERE k.type = 1 AND a.session_id <> b.session_id"),
            10);
  EXPECT_EQ(sqlCount(path_,
                     "SELECT count(*) FROM links k JOIN locations a ON a.id = k.location_a "
                     "JOIN locations b ON b.id = k.location_b "
                     "WHERE k.type = 0 AND a.session_id <> b.session_id"),
            0)
      << "neighbour links never join two sessions";
}

TEST_F(EngineTest, LocalisationFindsThePlaceAndChangesNothing) {
  {
    auto map = Map::open(path_.string(), Options());
    map->beginSession("first half");
    for (std::size_t i = 0; i < 40; ++i) map->process(seq_->images[i], i, seq_->paths[i]);
  }
  const std::string before = readBytes(path_);
  auto map = Map::open(path_.string(), Options(), Map::Mode::kLocalisation);
  std::size_t found = 0;
  for (std::size_t i = 44; i < 80; i += 5) {  // revisits of frames i - 40
    auto q = map->query(seq_->images[i], 3);
    ASSERT_FALSE(q.matches.empty());
    for (const auto& f : q.matches.front().frames)
      if (std::llabs(f.source_index - (static_cast<std::int64_t>(i) - 40)) <= 5) {
        ++found;
        break;
      }
  }
  EXPECT_GE(found, 6u);
  EXPECT_THROW(map->beginSession("x"), Error);
  map.reset();
  EXPECT_EQ(readBytes(path_), before) << "localisation must leave the map byte-identical";
}

TEST_F(EngineTest, AnotherExtractorOnTheSameMapIsRefused) {
  {
    auto map = Map::open(path_.string(), Options());
    map->beginSession("surf");
    map->process(seq_->images[0], 0, "a");
  }
  Options sift;
  sift.extractor = Extractor::kSift;
  try {
    Map::open(path_.string(), sift);
    FAIL() << "a SIFT session on a SURF map was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find("surf-64"), std::string::npos) << e.what();
  }
}

TEST(Options, UnknownKeysAndBadValuesAreRefusedWithTheValidOnes) {
  try {
    Options::fromSettings({{"t_lop", "0.1"}});
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("t_loop"), std::string::npos) << e.what();
  }
  try {
    Options::fromSettings({{"word_rule", "fancy"}});
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("greedy|nndr"), std::string::npos) << e.what();
  }
  EXPECT_THROW(Options::fromSettings({{"t_loop", "1.5"}}), Error);
  EXPECT_THROW(Options::fromSettings({{"stm_size", "ten"}}), Error);
  Options o = Options::fromSettings({{"wm_max", "50"}, {"upright", "true"}});
  EXPECT_EQ(o.wm_max, 50);
  EXPECT_TRUE(o.upright);
  EXPECT_EQ(Options::fromSettings(o.toSettings()).toSettings(), o.toSettings());
}

}  // namespace
}  // namespace placedb::testing
