// Temporal consistency: a hypothesis that fails the geometric rule on its own (fewer inliers
// than geometry_min_inliers, NFA above geometry_max_nfa) passes the relaxed one when it
// continues the run of loop closures of the last few frames, and the run it
// continues from survives closing and reopening the map (the WM keypoint cache starts empty).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>

#include "engine_fixture.h"
#include "synthetic/synthetic_sequence.h"
#include "walk_frames.h"

namespace placedb::testing {
namespace {

using Truth = std::map<std::int64_t, std::vector<std::int64_t>>;  // frame -> frames it revisits

Truth loadTruth(const std::filesystem::path& dir) {
  Truth truth;
  std::ifstream gt(dir / "gt_pairs.txt");
  std::string line;
  while (std::getline(gt, line)) {
    std::istringstream fields(line);
    std::int64_t q, r;
    if (!line.empty() && line[0] != '#' && fields >> q >> r) truth[q].push_back(r);
  }
  return truth;
}

// Whether a frame's hypothesis covers one of its ground-truth places, within 10 frames.
bool rightPlace(const Truth& truth, std::size_t frame, const Frame& f) {
  auto it = truth.find(static_cast<std::int64_t>(frame));
  if (it == truth.end()) return false;
  for (std::int64_t c : f.source_indices)
    for (std::int64_t r : it->second)
      if (std::llabs(c - r) <= 10) return true;
  return false;
}

class TemporalTest : public ::testing::Test {
 protected:
  void SetUp() override {
    seq_ = rtabmapSamples();
    if (!seq_) GTEST_SKIP() << "no rtabmap_samples under " << datasetsDir();
    truth_ = loadTruth(dataset("rtabmap_samples"));
  }

  std::vector<Frame> run(const std::string& name, const Options& options,
                         const std::set<std::size_t>& stop_after = {}) {
    return mapFrames(*seq_, "rtabmap_samples", name, options, stop_after);
  }

  bool rightPlace(std::size_t frame, const Frame& f) const {
    return testing::rightPlace(truth_, frame, f);
  }

  const Sequence* seq_ = nullptr;
  Truth truth_;
};

// By the check's rule, for the frame alone or for a run of frames ending at it.
bool passesOnItsOwn(const Frame& f, const Options& options) {
  return f.inliers >= options.geometry_min_inliers ||
         f.log10_nfa <= std::log10(options.geometry_max_nfa) || f.evidence_frames > 1;
}

// Frames accepted although the check's rule would have refused them.
std::vector<std::size_t> temporalAcceptances(const std::vector<Frame>& frames,
                                             const Options& options) {
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < frames.size(); ++i)
    if (frames[i].accepted && !passesOnItsOwn(frames[i], options)) out.push_back(i);
  return out;
}

TEST_F(TemporalTest, WeakHypothesesNextToThePreviousClosureAreAcceptedAndRight) {
  Options on;
  ASSERT_GT(on.temporal_min_inliers, 0) << "temporal consistency is on by default";
  Options off = on;
  off.temporal_min_inliers = 0;
  off.temporal_max_nfa = 0;
  const auto with = run("temporal_on", on);
  const auto without = run("temporal_off", off);

  EXPECT_TRUE(temporalAcceptances(without, off).empty())
      << "without temporal consistency every accepted hypothesis passes the check's rule";
  const auto weak = temporalAcceptances(with, on);
  ASSERT_FALSE(weak.empty()) << "the corridor's revisits have frames with few inliers";
  for (std::size_t i : weak) {
    SCOPED_TRACE("frame " + std::to_string(i));
    EXPECT_TRUE(with[i].inliers >= on.temporal_min_inliers ||
                with[i].log10_nfa <= std::log10(on.temporal_max_nfa));
    // One of the temporal_max_gap frames before closed a loop on its own: temporal acceptances
    // never anchor the next ones.
    bool anchored = false;
    for (std::size_t back = 1; back <= static_cast<std::size_t>(on.temporal_max_gap); ++back)
      if (back <= i && with[i - back].accepted && passesOnItsOwn(with[i - back], on))
        anchored = true;
    EXPECT_TRUE(anchored);
    EXPECT_TRUE(rightPlace(i, with[i])) << "hypothesis frames " << with[i].source_indices.front();
  }

  // What it adds in all is measured where revisits have few features (ClosureRunGaps): on the
  // corridor, a weak continuation often stands in for a jump that passes on its own.
  for (std::size_t i = 0; i < with.size(); ++i) {
    if (with[i].accepted) {
      EXPECT_TRUE(rightPlace(i, with[i])) << "frame " << i;
    }
  }
}

TEST_F(TemporalTest, ResumingJustBeforeAWeakClosureGivesTheSameResult) {
  Options options;
  const auto straight = run("temporal_straight", options);
  const auto weak = temporalAcceptances(straight, options);
  ASSERT_FALSE(weak.empty());
  std::set<std::size_t> stops;
  for (std::size_t i : weak) stops.insert(i - 1);  // the map reopens between anchor and frame
  const auto resumed = run("temporal_resumed", options, stops);
  ASSERT_EQ(resumed.size(), straight.size());
  for (std::size_t i = 0; i < straight.size(); ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    EXPECT_EQ(resumed[i].accepted, straight[i].accepted);
    EXPECT_EQ(resumed[i].hypothesis, straight[i].hypothesis);
    EXPECT_EQ(resumed[i].inliers, straight[i].inliers);
  }
}

// lip6_outdoor_160x128's first revisit has frames whose every candidate misses the check a frame
// or two after the last closure that passed on its own: the closure run bridges them, they are
// the right places, and a map reopened just before each of them decides exactly as a straight run.
TEST(ClosureRunGaps, BridgedFramesAreRightAndResumeExactly) {
  const auto dir = dataset("lip6_outdoor_160x128");
  if (dir.empty()) GTEST_SKIP() << "no lip6_outdoor_160x128 under " << datasetsDir();
  const Sequence seq = loadSequence(dir, 600);
  const Truth truth = loadTruth(dir);
  const Options options;
  const auto strong = [&](const Frame& f) { return f.accepted && passesOnItsOwn(f, options); };
  const auto straight =
      mapFrames(seq, "lip6_outdoor_160x128", "ClosureRunGaps_straight", options, {});
  std::set<std::size_t> bridged, stops;
  for (std::size_t i = 1; i < straight.size(); ++i)
    if (straight[i].accepted && !strong(straight[i]) && !strong(straight[i - 1])) {
      bridged.insert(i);
      stops.insert(i - 1);
    }
  ASSERT_FALSE(bridged.empty()) << "frames 535 and 575-577 follow a frame without a closure";
  for (std::size_t i : bridged) EXPECT_TRUE(rightPlace(truth, i, straight[i])) << "frame " << i;
  Options off = options;
  off.temporal_min_inliers = 0;
  off.temporal_max_nfa = 0;
  const auto alone = mapFrames(seq, "lip6_outdoor_160x128", "ClosureRunGaps_off", off, {});
  const auto count = [](const std::vector<Frame>& frames) {
    std::size_t n = 0;
    for (const Frame& f : frames) n += f.accepted;
    return n;
  };
  EXPECT_GT(count(straight), count(alone)) << "temporal consistency adds closures";

  const auto resumed =
      mapFrames(seq, "lip6_outdoor_160x128", "ClosureRunGaps_resumed", options, stops);
  for (std::size_t i = 0; i < straight.size(); ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    EXPECT_EQ(resumed[i].accepted, straight[i].accepted);
    EXPECT_EQ(resumed[i].hypothesis, straight[i].hypothesis);
    EXPECT_EQ(resumed[i].inliers, straight[i].inliers);
  }
}

// lip6_outdoor_120x96's first revisits, at the images' own ~44 features, have frames (501, 568,
// 599, ...) that no single frame's check accepts, whose runs of frames matching consecutive places
// pass together (closure_evidence.h): they are the right places, and a map reopened in the middle
// of each run decides exactly as a straight one.
TEST(ClosureEvidenceRuns, RunsPassWhereNoFrameCouldAndResumeExactly) {
  const auto dir = dataset("lip6_outdoor_120x96");
  if (dir.empty()) GTEST_SKIP() << "no lip6_outdoor_120x96 under " << datasetsDir();
  const Sequence seq = loadSequence(dir, 660);
  const Truth truth = loadTruth(dir);
  // ~44 features a frame, the regime the rule is for: with the second search at twice the size
  // (feature_target) every closure of these frames passes on one frame's check.
  Options options;
  options.feature_target = 0;
  const auto straight =
      mapFrames(seq, "lip6_outdoor_120x96", "ClosureEvidenceRuns_straight", options, {});
  std::set<std::size_t> by_runs, stops;
  for (std::size_t i = 1; i < straight.size(); ++i) {
    const Frame& f = straight[i];
    if (!f.accepted || f.evidence_frames < 2) continue;
    // Too weak alone: above the check's bar (the default rule is a contrario alone, so a
    // count of inliers is no bar of its own).
    if (options.geometry_rule != GeometryRule::kNfa) {
      EXPECT_LT(f.inliers, options.geometry_min_inliers) << "frame " << i;
    }
    EXPECT_GT(f.log10_nfa, std::log10(options.geometry_max_nfa)) << "frame " << i;
    by_runs.insert(i);
    stops.insert(i - 1);  // the map reopens between the run's frames
  }
  ASSERT_FALSE(by_runs.empty()) << "no closure passed as a run of frames";
  for (std::size_t i : by_runs) EXPECT_TRUE(rightPlace(truth, i, straight[i])) << "frame " << i;

  const auto resumed =
      mapFrames(seq, "lip6_outdoor_120x96", "ClosureEvidenceRuns_resumed", options, stops);
  for (std::size_t i = 0; i < straight.size(); ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    EXPECT_EQ(resumed[i].accepted, straight[i].accepted);
    EXPECT_EQ(resumed[i].hypothesis, straight[i].hypothesis);
    EXPECT_EQ(resumed[i].inliers, straight[i].inliers);
    EXPECT_EQ(resumed[i].evidence_frames, straight[i].evidence_frames);
  }
}

// Only a closure that starts a run must be what the frame's way here singles out
// (decision/way_here.h); one that continues the run leans on that start, also when the agreeing
// neighbour it is then named on lies beyond the run's reach. lip6_outdoor's closures are all right
// places, and none is refused on its way here (frame 988, a relaxed continuation named on such a
// neighbour, was while continuations were judged too).
TEST(ClosureRunGaps, TheWayHereJudgesTheStartsOfRunsOnly) {
  const auto dir = dataset("lip6_outdoor");
  if (dir.empty()) GTEST_SKIP() << "no lip6_outdoor under " << datasetsDir();
  const Sequence seq = loadSequence(dir, 1000);
  const auto frames = mapFrames(seq, "lip6_outdoor", "WayHereStarts", Options(), {});
  for (std::size_t i = 0; i < frames.size(); ++i)
    EXPECT_NE(frames[i].rejected.rfind("way here", 0), 0u)
        << "frame " << i << ": " << frames[i].rejected;
}

// A walk on the ground world that drives part of its route again (960x540, 0.5 m a frame) with
// exact ground truth: every closure accepted names a frame within 2 of one whose view overlaps
// the frame's. Where the second pass turns off the first, at frame 447, the place the run follows
// shares one object with the frame, not its scene; without ending the run there, the next three
// frames passed the relaxed rule on it with nothing of the first pass in view.
TEST(ClosureRunEnd, AClosureRunEndsWhereItsPlaceSharesOnlyAnObject) {
  const synthetic::SyntheticSequence walk(revisitingWalk());
  const Sequence seq = rendered(walk, "walk");
  Truth truth;
  for (const auto& [q, r] : walk.groundTruth()) truth[q].push_back(r);
  const auto frames = mapFrames(seq, "walk", "ClosureRunEnd", Options(), {});
  int accepted = 0;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if (!frames[i].accepted) continue;
    ++accepted;
    bool right = false;
    for (std::int64_t c : frames[i].source_indices)
      for (std::int64_t r : truth[static_cast<std::int64_t>(i)]) right |= std::llabs(c - r) <= 2;
    EXPECT_TRUE(right) << "frame " << i << " accepted on frame "
                       << (frames[i].source_indices.empty() ? -1 : frames[i].source_indices[0]);
  }
  EXPECT_GT(accepted, 200) << "the walk's second pass is found";
}

// A refutation, like a closure run, carries over to the next frames (way_here.h), so it lives in
// the map's engine state: closed and reopened between a refusal and the frame that continues it,
// the corridor's single pass decides exactly as in one go.
TEST(WayHereRefutations, CarryOverAStopAndResumeExactly) {
  synthetic::SyntheticOptions o = synthetic::sceneDefaults("corridor");
  o.lookalike = "corridor";
  o.frames = 200;
  o.width = 160;
  o.height = 120;
  o.hfov_degrees = 95;
  o.speed = 0.3;
  const Sequence seq = rendered(synthetic::SyntheticSequence(o), "corridor");
  const auto straight = mapFrames(seq, "corridor", "RefutationsStraight", Options(), {});
  std::set<std::size_t> stops;
  for (std::size_t i = 1; i < straight.size(); ++i)
    if (straight[i].rejected.find("was refused as a pattern") != std::string::npos)
      stops.insert(i - 1);
  ASSERT_FALSE(stops.empty()) << "the corridor continues refutations";
  const auto resumed = mapFrames(seq, "corridor", "RefutationsResumed", Options(), stops);
  ASSERT_EQ(resumed.size(), straight.size());
  for (std::size_t i = 0; i < straight.size(); ++i) {
    EXPECT_EQ(resumed[i].accepted, straight[i].accepted) << "frame " << i;
    EXPECT_EQ(resumed[i].rejected, straight[i].rejected) << "frame " << i;
  }
}

TEST(TemporalOptions, RangesAndRoundTrip) {
  EXPECT_THROW(Options::fromSettings({{"temporal_max_gap", "0"}}), Error);
  EXPECT_THROW(Options::fromSettings({{"temporal_max_gap", "101"}}), Error);
  EXPECT_THROW(Options::fromSettings({{"temporal_min_inliers", "-1"}}), Error);
  EXPECT_THROW(Options::fromSettings({{"temporal_radius", "101"}}), Error);
  Options o = Options::fromSettings(
      {{"temporal_min_inliers", "9"}, {"temporal_radius", "4"}, {"temporal_max_gap", "3"}});
  EXPECT_EQ(o.temporal_min_inliers, 9);
  EXPECT_EQ(o.temporal_radius, 4);
  EXPECT_EQ(o.temporal_max_gap, 3);
  EXPECT_EQ(Options::fromSettings(o.toSettings()).toSettings(), o.toSettings());
  EXPECT_EQ(Options::paperPreset().temporal_min_inliers, 0) << "the papers verify nothing";
}

}  // namespace
}  // namespace placedb::testing
