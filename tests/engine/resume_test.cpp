// Exact resume: a run stopped after any frame and resumed gives the same per-frame results as a
// run that never stopped, also when transfer and retrieval move locations between tiers.
#include <gtest/gtest.h>

#include "engine_fixture.h"

namespace placedb::testing {
namespace {

class ResumeTest : public ::testing::TestWithParam<int> {
 protected:
  void SetUp() override {
    seq_ = rtabmapSamples();
    if (!seq_) GTEST_SKIP() << "no rtabmap_samples under " << datasetsDir();
  }

  // Maps every frame, closing and reopening the map after each `stop_every` frames.
  std::vector<Outcome> run(const std::string& name, const Options& options, int stop_every,
                           bool check_consistency) {
    auto path = scratchDir(name) / "map.placedb";
    removeMap(path);
    std::vector<Outcome> out;
    std::unique_ptr<Map> map;
    for (std::size_t i = 0; i < seq_->images.size(); ++i) {
      if (!map) {
        map = Map::open(path.string(), options);
        if (i == 0)
          map->beginSession("rtabmap_samples");
        else
          map->resumeSession(map->lastSession()->id);
      }
      out.push_back(outcomeOf(map->process(seq_->images[i], i, seq_->paths[i])));
      if (check_consistency) {
        std::string problem = impl(*map).checkConsistency();
        EXPECT_EQ(problem, "") << "after frame " << i;
      }
      if (stop_every > 0 && (i + 1) % stop_every == 0) map.reset();  // destructor closes
    }
    return out;
  }

  void expectSame(const std::vector<Outcome>& a, const std::vector<Outcome>& b) {
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
      SCOPED_TRACE("frame " + std::to_string(i));
      EXPECT_EQ(a[i].location, b[i].location);
      EXPECT_EQ(a[i].outcome, b[i].outcome);
      EXPECT_EQ(a[i].hypothesis, b[i].hypothesis);
      EXPECT_EQ(a[i].accepted, b[i].accepted);
      EXPECT_NEAR(a[i].posterior, b[i].posterior, 1e-6);
      EXPECT_NEAR(a[i].score, b[i].score, 1e-6);
      EXPECT_EQ(a[i].wm, b[i].wm);
      EXPECT_EQ(a[i].stm, b[i].stm);
      EXPECT_EQ(a[i].vocabulary, b[i].vocabulary);
      EXPECT_EQ(a[i].transferred, b[i].transferred);
      EXPECT_EQ(a[i].retrieved, b[i].retrieved);
    }
  }

  const Sequence* seq_ = nullptr;
};

TEST_P(ResumeTest, StoppedEveryTenthFrameEqualsStraightRun) {
  Options options;
  options.wm_max = GetParam();
  auto straight = run("straight" + std::to_string(GetParam()), options, 0, true);
  auto split = run("split" + std::to_string(GetParam()), options, 10, false);
  expectSame(straight, split);

  std::size_t transferred = 0, retrieved = 0, accepted = 0;
  for (const auto& o : straight) {
    transferred += o.transferred;
    retrieved += o.retrieved;
    accepted += o.accepted;
  }
  EXPECT_GT(accepted, 10u) << "the sequence should close loops";
  if (GetParam() > 0) {
    // The bound must really move locations both ways, or the test proves nothing about tiers.
    EXPECT_GT(transferred, 0u);
    EXPECT_GT(retrieved, 0u);
    for (const auto& o : straight) EXPECT_LE(o.wm, static_cast<std::size_t>(GetParam()));
  }
}

INSTANTIATE_TEST_SUITE_P(WorkingMemoryBound, ResumeTest, ::testing::Values(0, 12),
                         [](const auto& info) {
                           return info.param ? "wm_max_" + std::to_string(info.param)
                                             : std::string("unbounded");
                         });

}  // namespace
}  // namespace placedb::testing
