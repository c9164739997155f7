// Two writers of one map on a PostgreSQL server, interleaved frame by frame in one process so
// that every run is repeatable: the second begins a side session from the first's memory, finds
// the places the first stores after it began (through the LTM search), hands out ids of its own,
// and resumes exactly, as does the main line beside it. rtabmap_samples revisits its frames 0-38
// from frame 40 on: writer 1 maps 0-39, writer 2 maps 40-83.
#include <gtest/gtest.h>

#include <set>

#include "engine_fixture.h"
#include "pg_test_server.h"
#include "placedb/storage/map_store.h"

namespace placedb::testing {
namespace {

constexpr std::size_t kFork = 20;     // writer 2 begins when writer 1 has mapped this many
constexpr std::size_t kRevisit = 40;  // writer 2's first frame

bool same(const Outcome& a, const Outcome& b) {
  return a.location == b.location && a.hypothesis == b.hypothesis && a.outcome == b.outcome &&
         a.posterior == b.posterior && a.score == b.score && a.accepted == b.accepted &&
         a.wm == b.wm && a.stm == b.stm && a.vocabulary == b.vocabulary &&
         a.transferred == b.transferred && a.retrieved == b.retrieved &&
         a.retrieved_by_search == b.retrieved_by_search;
}

struct FleetRun {
  std::vector<Outcome> first, second;  // per frame of each writer
  std::vector<FrameResult> second_results;
};

// Writer 1 maps frames 0-39 (frames [kFork, 40) one for one with writer 2's first ones), writer 2
// frames 40-83. stop_first / stop_second: after how many of its frames a writer closes and
// resumes in a new Map (0: never).
FleetRun runFleet(const std::string& uri, const Sequence& seq, std::size_t stop_first,
                  std::size_t stop_second) {
  FleetRun out;
  Options options;
  auto one = Map::open(uri, options);
  const std::int64_t s1 = one->beginSession("writer-1").id;
  std::size_t i = 0;
  const auto step1 = [&] {
    if (stop_first && i == stop_first) {
      one.reset();
      one = Map::open(uri, options);
      one->resumeSession(s1);
    }
    out.first.push_back(outcomeOf(one->process(seq.images[i], i, seq.paths[i])));
    ++i;
  };
  while (i < kFork) step1();
  auto two = Map::open(uri, options);
  const std::int64_t s2 = two->beginSession("writer-2").id;
  std::size_t j = kRevisit;
  const auto step2 = [&] {
    if (stop_second && j - kRevisit == stop_second) {
      two.reset();
      two = Map::open(uri, options);
      two->resumeSession(s2);
    }
    FrameResult r = two->process(seq.images[j], j - kRevisit, seq.paths[j]);
    out.second.push_back(outcomeOf(r));
    out.second_results.push_back(r);
    ++j;
  };
  while (i < kRevisit || j < seq.images.size()) {
    if (i < kRevisit) step1();
    if (j < seq.images.size()) step2();
  }
  EXPECT_EQ(impl(*one).checkConsistency(), "");
  EXPECT_EQ(impl(*two).checkConsistency(), "");
  one->close();
  two->close();
  return out;
}

class FleetEngine : public SamplesMapTest {
 protected:
  void SetUp() override {
    SamplesMapTest::SetUp();
    if (IsSkipped()) return;
    std::string why;
    auto server = pgServerUri(&why);
    if (!server) GTEST_SKIP() << "PostgreSQL tests skipped: " << why;
    server_ = *server;
  }
  std::string database(const std::string& suffix) {
    return freshPgDatabase(server_, pgTestDatabaseName() + suffix);
  }
  std::string server_;
};

TEST_F(FleetEngine, SecondWriterFindsThePlacesTheFirstStoresAfterItBegan) {
  const std::string uri = database("");
  const FleetRun run = runFleet(uri, *seq_, 0, 0);
  auto store = storage::openMapStore(uri, storage::OpenMode::kReadOnly);
  EXPECT_EQ(store->sessionMemory(1), storage::SessionMemory::kMainLine);
  EXPECT_EQ(store->sessionMemory(2), storage::SessionMemory::kOwn);
  EXPECT_EQ(store->frameCount(1), static_cast<std::int64_t>(kRevisit));
  EXPECT_EQ(store->frameCount(2), static_cast<std::int64_t>(seq_->images.size() - kRevisit));
  // Writer 2 closes loops onto writer 1's places, also onto those writer 1 stored after writer 2
  // began (frames kFork-39), which only the places it learns each frame can give it.
  std::set<std::int64_t> onto;
  for (const FrameResult& r : run.second_results)
    if (r.hypothesis.accepted)
      for (const FrameRef& f : r.hypothesis.frames)
        if (f.session_id == 1) onto.insert(f.source_index);
  EXPECT_GE(onto.size(), 20u);
  EXPECT_TRUE(onto.lower_bound(static_cast<std::int64_t>(kFork)) != onto.end())
      << "no closure onto a place stored after writer 2 began";
  // Ids from disjoint blocks: no row of one writer took another's id.
  const auto locations = store->locationsInTier(storage::Tier::kLtm);
  std::set<std::int64_t> ids;
  for (const auto& l : locations) ids.insert(l.id);
  EXPECT_EQ(ids.size(), locations.size());
}

// Each writer stopped and resumed in the middle of the interleaving decides as when it never
// stopped: the side session's own memory and the main line's restore exactly.
TEST_F(FleetEngine, EitherWriterResumesExactly) {
  const FleetRun straight = runFleet(database("_straight"), *seq_, 0, 0);
  const FleetRun resumed = runFleet(database("_resumed"), *seq_, 27, 17);
  ASSERT_EQ(straight.first.size(), resumed.first.size());
  ASSERT_EQ(straight.second.size(), resumed.second.size());
  for (std::size_t k = 0; k < straight.first.size(); ++k)
    EXPECT_TRUE(same(straight.first[k], resumed.first[k])) << "writer 1, frame " << k;
  for (std::size_t k = 0; k < straight.second.size(); ++k)
    EXPECT_TRUE(same(straight.second[k], resumed.second[k])) << "writer 2, frame " << k;
}

}  // namespace
}  // namespace placedb::testing
