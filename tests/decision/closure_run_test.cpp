// Which locations continue a run of loop closures: either side of the anchor on the next frame,
// only ahead of it in the run's heading a few frames later, and nothing once the gap is too long,
// the session another, or the run without a heading.
#include <gtest/gtest.h>

#include <optional>

#include "decision/closure_run.h"
#include "map/engine_state.h"
#include "map/state_keys.h"
#include "placedb/storage/sqlite_map_store.h"
#include "test_paths.h"

namespace placedb {
namespace {

constexpr RunSettings kSettings{2, 4};  // temporal_radius, temporal_max_gap
constexpr std::int64_t kSession = 1;

// The run after closures on `locations` in consecutive frames from `frame`, each within the
// reach of the one before.
ClosureRun runThrough(std::initializer_list<LocationId> locations, std::int64_t frame = 100) {
  ClosureRun run;
  bool continues = false;
  for (LocationId location : locations) {
    run = anchorAt(run, location, frame++, kSession, continues, kSettings);
    continues = true;
  }
  return run;
}

TEST(ClosureRun, NextFrameReachesEitherSideWithinTheRadius) {
  const ClosureRun run = runThrough({50});
  const std::optional<RunReach> reach = reachOf(run, run.frame + 1, kSession, kSettings);
  ASSERT_TRUE(reach);
  EXPECT_EQ(reach->links, 2);
  EXPECT_TRUE(reach->admits(50, 48));
  EXPECT_TRUE(reach->admits(50, 52));
}

TEST(ClosureRun, JitterGivesNoHeadingAndSoNoReachAfterAGap) {
  const ClosureRun run = runThrough({50, 49, 51, 52});  // within the radius of the first
  EXPECT_EQ(run.heading, 0);
  EXPECT_FALSE(reachOf(run, run.frame + 2, kSession, kSettings))
      << "without a heading a gap could only be bridged backwards as well";
  EXPECT_TRUE(reachOf(run, run.frame + 1, kSession, kSettings));
}

TEST(ClosureRun, AGapReachesAheadOnlyAndFartherTheLongerItIs) {
  const ClosureRun forward = runThrough({50, 51, 52, 53});
  ASSERT_EQ(forward.heading, 1);
  for (std::int64_t gap = 2; gap <= kSettings.max_gap; ++gap) {
    SCOPED_TRACE("gap " + std::to_string(gap));
    const std::optional<RunReach> reach =
        reachOf(forward, forward.frame + gap, kSession, kSettings);
    ASSERT_TRUE(reach);
    EXPECT_EQ(reach->links, kSettings.radius + gap - 1) << "the camera moved on meanwhile";
    EXPECT_TRUE(reach->admits(53, 53));
    EXPECT_TRUE(reach->admits(53, 55));
    EXPECT_FALSE(reach->admits(53, 52)) << "behind the anchor lies the drift back along the graph";
  }
  EXPECT_FALSE(reachOf(forward, forward.frame + kSettings.max_gap + 1, kSession, kSettings));

  const ClosureRun backward = runThrough({80, 79, 78, 77});  // a path retraced the other way
  ASSERT_EQ(backward.heading, -1);
  const std::optional<RunReach> reach = reachOf(backward, backward.frame + 3, kSession, kSettings);
  ASSERT_TRUE(reach);
  EXPECT_TRUE(reach->admits(77, 74));
  EXPECT_FALSE(reach->admits(77, 78));
}

TEST(ClosureRun, AnotherSessionOrAnEarlierFrameContinuesNothing) {
  const ClosureRun run = runThrough({50, 51, 52, 53});
  EXPECT_FALSE(reachOf(run, run.frame + 1, kSession + 1, kSettings));
  EXPECT_FALSE(reachOf(run, run.frame, kSession, kSettings));
  EXPECT_FALSE(reachOf(ClosureRun{}, 5, kSession, kSettings)) << "no closure yet";
}

TEST(ClosureRun, AJumpStartsANewRunThatKeepsTheHeadingOnlyWhenItFollowsClosely) {
  const ClosureRun run = runThrough({500, 501, 502, 503});
  ASSERT_EQ(run.heading, 1);
  // Another visit of the place, two frames on: the camera still moves the same way.
  const ClosureRun jumped = anchorAt(run, 60, run.frame + 2, kSession, false, kSettings);
  EXPECT_EQ(jumped.first, 60);
  EXPECT_EQ(jumped.heading, 1);
  const ClosureRun jittered = anchorAt(jumped, 59, jumped.frame + 1, kSession, true, kSettings);
  EXPECT_EQ(jittered.heading, 1) << "a link back is jitter, not a new heading";
  const ClosureRun turned =
      anchorAt(runThrough({60, 59}), 56, run.frame + 2, kSession, true, kSettings);
  EXPECT_EQ(turned.heading, -1) << "beyond the radius from the run's first closure";

  const ClosureRun later =
      anchorAt(run, 60, run.frame + kSettings.max_gap + 1, kSession, false, kSettings);
  EXPECT_EQ(later.heading, 0) << "after a break the camera may have turned";
  const ClosureRun elsewhere = anchorAt(run, 60, run.frame + 1, kSession + 1, false, kSettings);
  EXPECT_EQ(elsewhere.heading, 0);
}

TEST(ClosureRun, SurvivesTheMapsCountersAndOlderMapsLoadARunOfOne) {
  const auto path = (testing::scratchDir("ClosureRun_counters") / "map.placedb").string();
  storage::SqliteMapStore store(path, storage::OpenMode::kReadWrite);
  EngineCounters saved;
  saved.closure_run = runThrough({500, 501, 502, 503}, 40);
  saved.closure_run.session = 3;
  {
    storage::Transaction t = store.begin();
    saved.save(store);
    t.commit();
  }
  EngineCounters loaded;
  ASSERT_TRUE(loaded.load(store));
  EXPECT_EQ(loaded.closure_run.anchor, 503);
  EXPECT_EQ(loaded.closure_run.frame, 43);
  EXPECT_EQ(loaded.closure_run.session, 3);
  EXPECT_EQ(loaded.closure_run.first, 500);
  EXPECT_EQ(loaded.closure_run.heading, 1) << "a resumed run bridges the same gaps";

  {  // the counters of a map made before runs had a first closure and a heading
    storage::Transaction t = store.begin();
    store.putState(kCountersKey,
                   std::string(R"({"next_frame_id":44,"next_location_id":600,"feature_sum":0,)"
                               R"("feature_frames":0,"last_location":599,"last_session":3,)"
                               R"("previous_score":0,"last_closure_location":503,)"
                               R"("last_closure_frame":43,"last_closure_session":3})"));
    t.commit();
  }
  ASSERT_TRUE(loaded.load(store));
  EXPECT_EQ(loaded.closure_run.anchor, 503);
  EXPECT_EQ(loaded.closure_run.first, 503);
  EXPECT_EQ(loaded.closure_run.heading, 0);
}

}  // namespace
}  // namespace placedb
