// Camera intrinsics on real frames: accepted loop closures carry a relative pose, the decisions
// are those of a run without intrinsics, and a resumed session keeps its camera.
#include <gtest/gtest.h>

#include <cmath>

#include "engine_fixture.h"
#include "placedb/storage/sqlite_map_store.h"

namespace placedb::testing {
namespace {

// rtabmap_samples are 512x384; their camera is not published. A ~63 degree horizontal field of
// view is assumed: the test asks for a plausible pose, not the true one.
Options withCamera() {
  Options o;
  o.fx = 420;
  o.fy = 420;
  o.cx = 256;
  o.cy = 192;
  return o;
}

struct Mapped {
  std::vector<FrameResult> results;
  std::vector<storage::ClosurePoseRecord> stored;
};

// Maps the samples, stopping (closing and reopening with default options) after `stop_at`
// frames when it is not 0.
Mapped mapSamples(const std::string& name, const Options& options, std::size_t stop_at = 0) {
  const Sequence& seq = *rtabmapSamples();
  const auto path = scratchDir("ClosurePose") / (name + ".placedb");
  Mapped run;
  std::unique_ptr<Map> map = openForFrame(path, options, 0, "samples");
  for (std::size_t i = 0; i < seq.images.size(); ++i) {
    if (stop_at != 0 && i == stop_at) {
      map->close();
      map.reset();
      map = openForFrame(path, Options(), i, "samples");  // the session's own settings return
    }
    run.results.push_back(map->process(seq.images[i], static_cast<std::int64_t>(i), seq.paths[i]));
  }
  map->close();
  map.reset();
  run.stored = storage::SqliteMapStore(path.string(), storage::OpenMode::kReadOnly).closurePoses();
  return run;
}

class ClosurePoseTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!rtabmapSamples()) GTEST_SKIP() << "no rtabmap_samples under " << datasetsDir();
  }
};

TEST_F(ClosurePoseTest, IntrinsicsAddPosesAndChangeNoDecision) {
  const Mapped plain = mapSamples("plain", Options());
  const Mapped posed = mapSamples("posed", withCamera());
  ASSERT_EQ(plain.results.size(), posed.results.size());
  int accepted = 0, with_pose = 0;
  for (std::size_t i = 0; i < plain.results.size(); ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    const auto &a = plain.results[i], &b = posed.results[i];
    EXPECT_EQ(a.location_id, b.location_id);
    EXPECT_EQ(a.hypothesis.location_id, b.hypothesis.location_id);
    EXPECT_EQ(a.hypothesis.accepted, b.hypothesis.accepted);
    EXPECT_EQ(a.hypothesis.score, b.hypothesis.score);
    EXPECT_EQ(a.hypothesis.inliers, b.hypothesis.inliers);
    EXPECT_FALSE(a.hypothesis.pose);
    if (!b.hypothesis.accepted) {
      EXPECT_FALSE(b.hypothesis.pose);
      continue;
    }
    ++accepted;
    if (!b.hypothesis.pose) continue;
    ++with_pose;
    const auto& p = *b.hypothesis.pose;
    EXPECT_NEAR(p.qw * p.qw + p.qx * p.qx + p.qy * p.qy + p.qz * p.qz, 1.0, 1e-9);
    const double t = std::sqrt(p.tx * p.tx + p.ty * p.ty + p.tz * p.tz);
    EXPECT_TRUE(std::abs(t - 1.0) < 1e-9 || t == 0.0) << t;
    EXPECT_GE(p.inliers, 5);
    // A revisit of a hand-held walk: the camera turned by less than 90 degrees.
    EXPECT_GT(p.qw, std::cos(M_PI / 4)) << p.qw;
  }
  EXPECT_GT(accepted, 20);
  EXPECT_GE(with_pose * 10, accepted * 9) << with_pose << " of " << accepted;
  EXPECT_TRUE(plain.stored.empty());
  EXPECT_EQ(static_cast<int>(posed.stored.size()), with_pose);
}

TEST_F(ClosurePoseTest, ResumedSessionKeepsItsCameraAndItsPoses) {
  const Mapped straight = mapSamples("straight", withCamera());
  const Mapped resumed = mapSamples("resumed", withCamera(), 40);
  ASSERT_FALSE(straight.stored.empty());
  ASSERT_EQ(straight.stored.size(), resumed.stored.size());
  for (std::size_t i = 0; i < straight.stored.size(); ++i) {
    const auto &a = straight.stored[i], &b = resumed.stored[i];
    EXPECT_EQ(a.frame_id, b.frame_id);
    EXPECT_EQ(a.hypothesis_location_id, b.hypothesis_location_id);
    EXPECT_EQ(a.pose.qw, b.pose.qw);
    EXPECT_EQ(a.pose.qx, b.pose.qx);
    EXPECT_EQ(a.pose.ty, b.pose.ty);
    EXPECT_EQ(a.pose.inliers, b.pose.inliers);
  }
  EXPECT_GT(std::count_if(resumed.stored.begin(), resumed.stored.end(),
                          [](const auto& r) { return r.frame_id > 41; }),
            0);
}

TEST(CameraSettings, AllFourOrNone) {
  Options o;
  o.fx = 190;
  try {
    o.validate();
    ADD_FAILURE() << "fx alone was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find("fx fy cx cy"), std::string::npos) << e.what();
  }
  const auto map = scratchDir("AllFourOrNone") / "m.placedb";
  EXPECT_THROW(Map::open(map.string(), o), Error);
  EXPECT_FALSE(std::filesystem::exists(map));  // refused before the file is made
  const Options camera =
      Options::fromSettings({{"fx", "190"}, {"fy", "191"}, {"cx", "120"}, {"cy", "96"}});
  EXPECT_NO_THROW(camera.validate());
  EXPECT_TRUE(camera.hasIntrinsics());
  EXPECT_EQ(camera.toSettings().at("fy"), "191");
  EXPECT_EQ(Options().toSettings().at("cx"), "0");
  EXPECT_FALSE(Options().hasIntrinsics());
  EXPECT_THROW(Options::fromSettings({{"fx", "-1"}}), Error);
}

}  // namespace
}  // namespace placedb::testing
