// Where a map must accept nothing: walks that never come back to a place. Each dev set cut before
// its first revisit, synthetic walks past one poster that stands at two places and down a
// corridor whose doors and lockers repeat, with the defaults and with working memory capped.
// Every closure accepted there is false, and one false closure breaks a SLAM back end's map, so
// each test fails on the first one and names it.
// bench/quality/precision.py runs the full cuts and the larger synthetic walks.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "engine_fixture.h"
#include "synthetic/synthetic_sequence.h"

namespace placedb::testing {
namespace {

// The frames a run accepted a closure on, with the frames each names.
std::vector<std::string> acceptedClosures(const std::vector<cv::Mat>& images,
                                          const std::string& name, const Options& options) {
  const auto path = scratchDir(name) / "map.placedb";
  removeMap(path);
  auto map = Map::open(path.string(), options);
  map->beginSession(name);
  std::vector<std::string> accepted;
  for (std::size_t i = 0; i < images.size(); ++i) {
    const FrameResult r = map->process(images[i], static_cast<std::int64_t>(i), name);
    if (!r.hypothesis.accepted) continue;
    std::string named;
    for (const auto& f : r.hypothesis.frames) named += " " + std::to_string(f.source_index);
    accepted.push_back(std::to_string(i) + " on" + named);
  }
  map->close();
  return accepted;
}

Options capped(int wm_max) {
  Options o;
  o.wm_max = wm_max;
  return o;
}

struct Cut {
  const char* dataset;
  std::size_t frames;  // before the first revisit (gt_pairs.txt's smallest q)
};

class DevSetCut : public ::testing::TestWithParam<Cut> {};

TEST_P(DevSetCut, AcceptsNoClosureWithTheDefaultsNorWithWorkingMemoryCapped) {
  const Cut cut = GetParam();
  const auto dir = dataset(cut.dataset);
  if (dir.empty()) GTEST_SKIP() << "no " << cut.dataset << " under " << datasetsDir();
  const Sequence seq = loadSequence(dir, cut.frames);
  const std::string name = std::string("cut_") + cut.dataset;
  EXPECT_EQ(acceptedClosures(seq.images, name, Options()), std::vector<std::string>());
  // A cap that binds within the cut: the 300 on the longer cuts, a third of the
  // locations on rtabmap_samples' 40 frames.
  const int wm_max = cut.frames > 100 ? 300 : 10;
  EXPECT_EQ(acceptedClosures(seq.images, name + "_capped", capped(wm_max)),
            std::vector<std::string>())
      << "wm_max=" << wm_max;
}

INSTANTIATE_TEST_SUITE_P(BeforeTheFirstRevisit, DevSetCut,
                         ::testing::Values(Cut{"rtabmap_samples", 40},
                                           Cut{"lip6_outdoor_120x96", 460},
                                           Cut{"lip6_outdoor_160x128", 460},
                                           Cut{"lip6_outdoor", 460}),
                         [](const auto& info) { return std::string(info.param.dataset); });

// A synthetic walk that never comes back accepts no closure, with the defaults and with working
// memory capped to a bound the walk's 200 frames cross.
void expectNoClosure(const synthetic::SyntheticSequence& walk, const std::string& name) {
  SCOPED_TRACE(name);
  ASSERT_TRUE(walk.groundTruth().empty());
  std::vector<cv::Mat> images;
  for (int i = 0; i < walk.size(); ++i) images.push_back(walk.render(i));
  EXPECT_EQ(acceptedClosures(images, name, Options()), std::vector<std::string>());
  EXPECT_EQ(acceptedClosures(images, name + "_capped", capped(30)), std::vector<std::string>())
      << "wm_max=30";
}

struct Camera {
  int width, height;
  double pitch_degrees;  // the small camera looks further down: its view is taller
};

// A camera's test name: its image size.
template <typename CameraParam>
std::string sizeName(const ::testing::TestParamInfo<CameraParam>& info) {
  return std::to_string(info.param.width) + "x" + std::to_string(info.param.height);
}

class LookalikeWalk : public ::testing::TestWithParam<Camera> {};

// A walk that never comes back, 0.5 m a frame, past one A0 poster laid at two places 48 frames
// apart (synthetic/lookalikes.h): everything else in the two views differs.
TEST_P(LookalikeWalk, OnePosterAtTwoPlacesIsNotAPlace) {
  synthetic::SyntheticOptions o;
  o.profile = "single_pass";
  o.lookalike = "poster";
  o.frames = 200;
  o.width = GetParam().width;
  o.height = GetParam().height;
  o.pitch_degrees = GetParam().pitch_degrees;
  o.camera_height = 1.5;
  o.speed = 0.5;
  expectNoClosure(synthetic::SyntheticSequence(o), "poster_walk");
}

INSTANTIATE_TEST_SUITE_P(SmallAndLargeCamera, LookalikeWalk,
                         ::testing::Values(Camera{160, 120, 40}, Camera{960, 540, 30}),
                         sizeName<Camera>);

// A single pass down a corridor, 0.3 m a frame, where a door and a bank of lockers repeat on both
// walls every 6 m (synthetic/lookalikes.h): every view agrees with every other one far beyond
// chance, and looking down it the far end stays in view. No place of it is a revisit. The small
// camera is a wide one (95 degrees), as on a robot indoors: its few features lie mostly on the
// doors and lockers, so a view whole pitches back agrees as well as the place itself would.
struct CorridorCamera {
  int width, height;
  double hfov_degrees;
};

class CorridorWalk : public ::testing::TestWithParam<CorridorCamera> {};

TEST_P(CorridorWalk, DoorsAndLockersThatRepeatAlongItAreNotAPlace) {
  synthetic::SyntheticOptions o = synthetic::sceneDefaults("corridor");
  o.lookalike = "corridor";
  o.frames = 200;
  o.width = GetParam().width;
  o.height = GetParam().height;
  o.hfov_degrees = GetParam().hfov_degrees;
  o.speed = 0.3;
  expectNoClosure(synthetic::SyntheticSequence(o), "corridor_walk");
}

INSTANTIATE_TEST_SUITE_P(
    SmallAndLargeCamera, CorridorWalk,
    ::testing::Values(CorridorCamera{160, 120, 95},
                      CorridorCamera{960, 540, synthetic::sceneDefaults("corridor").hfov_degrees}),
    sizeName<CorridorCamera>);

}  // namespace
}  // namespace placedb::testing
