// The candidates' checks, two at a time (map/paired_checks.h): each candidate gets the result
// of its own check, asked for in any order, whatever the thread count; the first is checked
// alone; and a map decides every frame as it does on one thread.
#include <gtest/gtest.h>

#include <algorithm>
#include <mutex>
#include <set>
#include <thread>

#include "engine_fixture.h"
#include "map/paired_checks.h"
#include "placedb/error.h"

namespace placedb::testing {
namespace {

// A candidate's view: as many keypoints as its id, none for ids in `empty`.
PairedChecks::Prepare viewsOf(std::set<LocationId> empty, std::vector<LocationId>* prepared) {
  return [empty, prepared](LocationId c) -> std::optional<GeometricView> {
    prepared->push_back(c);
    if (empty.count(c)) return std::nullopt;
    GeometricView view;
    view.points.assign(static_cast<std::size_t>(c), cv::Point2f(0, 0));
    return view;
  };
}

// A check whose result names its view, and that records the threads it ran on.
struct RecordingCheck {
  std::mutex mutex;
  std::set<std::thread::id> threads;
  PairedChecks::Check fn() {
    return [this](const GeometricView& view) {
      {
        std::lock_guard<std::mutex> lock(mutex);
        threads.insert(std::this_thread::get_id());
      }
      GeometricResult g;
      g.inliers = static_cast<int>(view.points.size());
      g.passed = g.inliers == 5;
      return g;
    };
  }
};

TEST(PairedChecksTest, EachCandidateGetsItsOwnCheckOnAnyThreadCount) {
  const std::vector<LocationId> order = {3, 1, 4, 2, 6, 5, 7};
  for (int threads : {1, 2}) {
    SCOPED_TRACE("threads " + std::to_string(threads));
    std::vector<LocationId> prepared;
    RecordingCheck check;
    PairedChecks checks(order, threads, viewsOf({4}, &prepared), check.fn());
    // In order, then a skip (as chooseCandidate's continuation, which asks for near ones only).
    for (LocationId c : {3, 1, 4, 2, 7}) {
      const std::optional<GeometricResult> g = checks(c);
      if (c == 4) {
        EXPECT_FALSE(g) << "a candidate without keypoints";
        continue;
      }
      ASSERT_TRUE(g) << "candidate " << c;
      EXPECT_EQ(g->inliers, c);
    }
    if (threads == 1) {
      EXPECT_EQ(checks.madeAhead(), 0u);
      EXPECT_EQ(prepared, (std::vector<LocationId>{3, 1, 4, 2, 7}));
    } else {
      // 1 went with 4, which has no keypoints, and 2 with 6, which was never asked for.
      EXPECT_EQ(checks.madeAhead(), 1u);
      // Each candidate read once, 6 too.
      std::vector<LocationId> sorted = prepared;
      std::sort(sorted.begin(), sorted.end());
      EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end());
      EXPECT_EQ(prepared.front(), 3);
      EXPECT_NE(std::find(prepared.begin(), prepared.end(), 6), prepared.end());
    }
  }
}

TEST(PairedChecksTest, TheFirstCandidateIsCheckedAlone) {
  std::vector<LocationId> prepared;
  RecordingCheck check;
  PairedChecks checks({5, 1, 2}, 2, viewsOf({}, &prepared), check.fn());
  const std::optional<GeometricResult> g = checks(5);
  ASSERT_TRUE(g);
  EXPECT_TRUE(g->passed);
  EXPECT_EQ(checks.madeAhead(), 0u) << "a frame whose first candidate passes checks one";
  EXPECT_EQ(prepared, std::vector<LocationId>{5});
  EXPECT_EQ(check.threads.size(), 1u);
}

TEST(PairedChecksTest, AReadThatFailsAheadFailsOnlyWhenAskedFor) {
  std::vector<LocationId> prepared;
  RecordingCheck check;
  const PairedChecks::Prepare views = viewsOf({}, &prepared);
  PairedChecks checks(
      {3, 1, 6, 7}, 2,
      [&](LocationId c) -> std::optional<GeometricView> {
        if (c == 6) throw Error(ErrorCode::kMapRefused, "keypoints of location 6 are damaged");
        return views(c);
      },
      check.fn());
  ASSERT_TRUE(checks(3));
  const std::optional<GeometricResult> g = checks(1);  // 6 is read ahead, and fails
  ASSERT_TRUE(g);
  EXPECT_EQ(g->inliers, 1);
  EXPECT_EQ(checks.madeAhead(), 0u);
  ASSERT_TRUE(checks(7)) << "a frame that stops before 6 never sees its damage";
  EXPECT_THROW(checks(6), Error) << "asked for, it fails as it would one by one";
}

TEST(PairedChecksTest, AFailureOfTheWholeMapGoesUpAtOnce) {
  std::vector<LocationId> prepared;
  RecordingCheck check;
  const PairedChecks::Prepare views = viewsOf({}, &prepared);
  PairedChecks checks(
      {3, 1, 6}, 2,
      [&](LocationId c) -> std::optional<GeometricView> {
        if (c == 6) throw Error(ErrorCode::kServerLost, "the map's server went away");
        return views(c);
      },
      check.fn());
  ASSERT_TRUE(checks(3));
  EXPECT_THROW(checks(1), Error);
}

// lip6_outdoor_120x96: few features, so many frames check candidate after candidate.
TEST(PairedChecksTest, AMapDecidesAsOnOneThread) {
  const auto dir = dataset("lip6_outdoor_120x96");
  if (dir.empty()) GTEST_SKIP() << "no lip6_outdoor_120x96 under " << datasetsDir();
  const Sequence seq = loadSequence(dir, 700);
  const auto run = [&](int threads) {
    Options options;
    options.threads = threads;
    const auto path = scratchDir("PairedChecks_" + std::to_string(threads)) / "map.placedb";
    removeMap(path);
    auto map = Map::open(path.string(), options);
    map->beginSession("lip6_outdoor_120x96");
    std::vector<FrameResult> out;
    for (std::size_t i = 0; i < seq.images.size(); ++i)
      out.push_back(map->process(seq.images[i], static_cast<std::int64_t>(i), seq.paths[i]));
    return out;
  };
  const auto one = run(1);
  const auto two = run(2);
  ASSERT_EQ(one.size(), two.size());
  int paired_frames = 0, accepted = 0;
  for (std::size_t i = 0; i < one.size(); ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    const auto& a = one[i].hypothesis;
    const auto& b = two[i].hypothesis;
    EXPECT_EQ(one[i].location_id, two[i].location_id);
    EXPECT_EQ(a.location_id, b.location_id);
    EXPECT_EQ(a.accepted, b.accepted);
    EXPECT_EQ(a.posterior, b.posterior);
    EXPECT_EQ(a.score, b.score);
    EXPECT_EQ(one[i].wm_size, two[i].wm_size);
    EXPECT_EQ(one[i].retrieved, two[i].retrieved);
    EXPECT_EQ(a.candidates_checked, b.candidates_checked);
    EXPECT_EQ(a.inliers, b.inliers);
    EXPECT_EQ(a.matches, b.matches);
    EXPECT_EQ(a.log10_nfa, b.log10_nfa);
    EXPECT_EQ(a.evidence_frames, b.evidence_frames);
    EXPECT_EQ(a.rejected_reason, b.rejected_reason);
    paired_frames += a.candidates_checked >= 3;
    accepted += a.accepted;
  }
  EXPECT_GT(paired_frames, 20) << "frames that check three candidates or more";
  EXPECT_GT(accepted, 20);
}

}  // namespace
}  // namespace placedb::testing
