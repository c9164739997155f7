// Evidence that adds up over frames (closure_evidence.h): on synthetic correspondences, a run of
// frames each too weak to pass alone passes exactly when the model says, a frame without a
// common geometry in the middle breaks it, and the run survives the map's counters.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "decision/closure_evidence.h"
#include "epipolar_pairs.h"
#include "geometry/epipolar_fit.h"
#include "map/engine_state.h"
#include "map/state_keys.h"
#include "placedb/options.h"
#include "placedb/storage/sqlite_map_store.h"
#include "test_paths.h"

namespace placedb {
namespace {

const double kPassAt = std::log10(Options().geometry_max_nfa);
constexpr int kAlternatives = 5;  // places within two links either way
const cv::Size2f kSmallView(120, 96);

// The model, written out: prod alternatives x F_k(prod NFA_i), F_k Fisher's combination.
double modelLog10Nfa(const std::vector<double>& log10_nfas) {
  const int k = static_cast<int>(log10_nfas.size());
  double log10_product = 0;
  for (double x : log10_nfas) log10_product += x;
  const double ln = -log10_product * std::log(10.0);
  double sum = 0, factorial = 1;
  for (int j = 0; j < k; ++j) {
    if (j > 0) factorial *= j;
    sum += std::pow(ln, j) / factorial;
  }
  return (k - 1) * std::log10(double(kAlternatives)) + log10_product + std::log10(sum);
}

// One frame's check of a true revisit with few features: `inliers` of `matches` pairs share the
// geometry, on a 120x96 view.
double weakFrame(int matches, int inliers, unsigned seed) {
  std::mt19937 rng(seed);
  const testing::Pairs p = testing::rigid(matches, matches - inliers, kSmallView, 0.3f, rng);
  EpipolarFitSettings settings;
  settings.max_error_px = Options().geometry_max_error_px;
  settings.max_nfa = Options().geometry_max_nfa;
  return fitEpipolar(p.a, p.b, kSmallView, settings).log10_nfa;
}

double unrelatedFrame(int matches, unsigned seed) {
  std::mt19937 rng(seed);
  const testing::Pairs p = testing::noise(matches, kSmallView, rng);
  EpipolarFitSettings settings;
  settings.max_error_px = Options().geometry_max_error_px;
  return std::min(99.0, fitEpipolar(p.a, p.b, kSmallView, settings).log10_nfa);
}

// Frames 100, 101, ... matching places 500, 501, ... of session 1.
ClosureEvidence runOf(const std::vector<double>& log10_nfas, ClosureEvidence e = {}) {
  for (double x : log10_nfas) {
    const std::int64_t frame = e.frame ? e.frame + 1 : 100;
    const LocationId place = e.location ? e.location + 1 : 500;
    e = addEvidence(e, place, frame, 1, x, e.location ? kAlternatives : 0);
  }
  return e;
}

TEST(ClosureEvidence, OneFrameIsJudgedAsTheCheckJudgesIt) {
  for (double x : {-5.0, -3.0, -2.9, 0.0, 1.5}) {
    const ClosureEvidence e = runOf({x});
    EXPECT_DOUBLE_EQ(e.log10_nfa, x);
    EXPECT_EQ(e.log10_nfa <= kPassAt, x <= kPassAt);
  }
}

// Frames of a true revisit with few features, none of which passes alone: ten of twelve pairs
// share the geometry on a 120x96 view.
std::vector<double> weakFrames(std::size_t count) {
  std::vector<double> frames;
  for (unsigned seed = 1; frames.size() < count && seed < 100; ++seed) {
    const double x = weakFrame(12, 10, seed);
    if (x > kPassAt && x < 0.0) frames.push_back(x);
  }
  return frames;
}

TEST(ClosureEvidence, WeakFramesInARowPassWhenTheModelSays) {
  const std::vector<double> frames = weakFrames(5);
  ASSERT_EQ(frames.size(), 5u);
  int first_pass = 0;
  for (std::size_t k = 1; k <= frames.size(); ++k) {
    const std::vector<double> run(frames.begin(), frames.begin() + static_cast<long>(k));
    const ClosureEvidence e = runOf(run);
    EXPECT_EQ(e.frames, static_cast<int>(k));
    EXPECT_NEAR(e.log10_nfa, modelLog10Nfa(run), 1e-9) << k << " frames";
    if (!first_pass && e.log10_nfa <= kPassAt) first_pass = static_cast<int>(k);
  }
  EXPECT_GT(first_pass, 1) << "together, frames pass that no frame passes alone";
}

TEST(ClosureEvidence, AWrongPlaceInTheMiddleBreaksTheRun) {
  const std::vector<double> frames = weakFrames(5);
  ASSERT_EQ(frames.size(), 5u);
  ASSERT_LE(runOf(frames).log10_nfa, kPassAt);
  const double wrong = unrelatedFrame(12, 77);
  ASSERT_GT(wrong, 0.0) << "unrelated pairs are no evidence";
  std::vector<double> broken(frames.begin(), frames.begin() + 3);
  broken.push_back(wrong);
  broken.insert(broken.end(), frames.begin() + 3, frames.end());
  const ClosureEvidence e = runOf(broken);
  EXPECT_EQ(e.frames, 2) << "only the frames after the wrong one count";
  EXPECT_NEAR(e.log10_nfa, modelLog10Nfa({frames[3], frames[4]}), 1e-9);
  EXPECT_GT(e.log10_nfa, kPassAt);
}

TEST(ClosureEvidence, OnlyThePlaceRightAfterInTheSameSessionContinues) {
  const ClosureEvidence e = runOf({-2.0, -2.0});
  ASSERT_EQ(e.frames, 2);
  EXPECT_TRUE(continuesEvidence(e, e.frame + 1, e.session));
  EXPECT_FALSE(continuesEvidence(e, e.frame + 2, e.session)) << "a frame skipped";
  EXPECT_FALSE(continuesEvidence(e, e.frame + 1, e.session + 1)) << "another session";
  EXPECT_EQ(addEvidence(e, 900, e.frame + 1, e.session, -2.0, 0).frames, 1)
      << "a place out of reach starts a run of its own";
}

TEST(ClosureEvidence, SurvivesTheMapsCountersAndOlderMapsHaveNone) {
  const auto path = (testing::scratchDir("ClosureEvidence_counters") / "map.placedb").string();
  storage::SqliteMapStore store(path, storage::OpenMode::kReadWrite);
  EngineCounters saved;
  saved.closure_evidence = runOf({-1.7, -2.3, -0.4});
  {
    storage::Transaction t = store.begin();
    saved.save(store);
    t.commit();
  }
  EngineCounters loaded;
  ASSERT_TRUE(loaded.load(store));
  const ClosureEvidence& a = saved.closure_evidence;
  const ClosureEvidence& b = loaded.closure_evidence;
  EXPECT_EQ(b.location, a.location);
  EXPECT_EQ(b.frame, a.frame);
  EXPECT_EQ(b.session, a.session);
  EXPECT_EQ(b.frames, a.frames);
  // Exactly, so that the next frame of a resumed run decides as in a straight one.
  EXPECT_EQ(b.log10_nfa, a.log10_nfa);
  EXPECT_EQ(b.log10_product, a.log10_product);
  EXPECT_EQ(b.log10_alternatives, a.log10_alternatives);

  {  // the counters of a map made before evidence added up over frames
    storage::Transaction t = store.begin();
    store.putState(kCountersKey,
                   std::string(R"({"next_frame_id":44,"next_location_id":600,"feature_sum":0,)"
                               R"("feature_frames":0,"last_location":599,"last_session":3,)"
                               R"("previous_score":0})"));
    t.commit();
  }
  ASSERT_TRUE(loaded.load(store));
  EXPECT_EQ(loaded.closure_evidence.location, 0);
  EXPECT_FALSE(continuesEvidence(loaded.closure_evidence, 44, 3));
}

}  // namespace
}  // namespace placedb
