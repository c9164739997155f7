// A mapper killed with SIGKILL at two dozen points -- while opening, between frames and inside a
// frame's transaction -- must leave a map that SQLite finds intact, that holds every frame the
// mapper reported committed, and that, resumed each time, ends equal to an uninterrupted run.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <iostream>
#include <random>
#include <thread>

#include "crash_scenario.h"
#include "reliability_support.h"

namespace placedb::testing {
namespace {

constexpr int kFrames = 100;
constexpr int kKills = 24;

// Frames 0..n-1 are all there, once each, and nothing else.
void expectContiguous(const std::map<std::int64_t, StoredFrame>& frames) {
  std::int64_t expected = 0;
  for (const auto& [index, frame] : frames) {
    EXPECT_EQ(index, expected) << "frame " << expected << " is missing";
    expected = index + 1;
  }
}

TEST(Crash, KilledTwentyFourTimesResumesToTheUninterruptedResult) {
  const auto dir = scratchDir("CrashKilled");
  const auto straight = dir / "straight.placedb", killed = dir / "killed.placedb";
  runMapper(straight, {"--frames", std::to_string(kFrames)});
  const auto expected = storedFrames(straight);
  ASSERT_EQ(expected.size(), std::size_t(kFrames));
  int accepted = 0;
  for (const auto& [index, frame] : expected) accepted += frame.accepted;
  EXPECT_GT(accepted, 0) << "the scenario should close loops, or resume is barely exercised";

  // PLACEDB_CRASH_SEED moves the kills elsewhere, to hunt for a kill point that breaks resume.
  const char* seed = std::getenv("PLACEDB_CRASH_SEED");
  std::mt19937 rng(seed ? static_cast<unsigned>(std::strtoul(seed, nullptr, 10)) : 2026u);
  const std::vector<std::string> killed_args = {"--frames", std::to_string(kFrames),
                                                "--slow-transactions", "1"};
  // Where the kills landed, judged by the child's last line before it died.
  int kills = 0, in_startup = 0, between_frames = 0, in_transaction = 0, in_commit = 0;
  std::int64_t committed = 0;  // frames the mapper reported, all runs together
  bool finished = false;
  while (kills < kKills && !finished) {
    ChildProcess child(mapperArgs(killed, killed_args));
    std::string last_line;
    bool ready_seen = false;
    auto consume = [&](const std::string& line) {
      ASSERT_EQ(line.rfind("error", 0), std::string::npos) << line;
      if (line.rfind("ready ", 0) == 0) {
        ready_seen = true;
        EXPECT_EQ(std::stoll(line.substr(6)), committed)
            << "resume must start right after the last committed frame";
      }
      if (line.rfind("frame ", 0) == 0) committed = std::stoll(line.substr(6)) + 1;
      if (line == "done") finished = true;
      last_line = line;
    };
    if (kills % 4 == 0) {
      // Anywhere from start-up through the first frames: opening, restoring, resuming.
      std::this_thread::sleep_for(std::chrono::milliseconds(rng() % 120));
    } else {
      // Let one to three frames commit, then kill a random moment into the next one.
      int frames_seen = 0;
      const int frames_before_kill = 1 + static_cast<int>(rng() % 3);
      while (frames_seen < frames_before_kill && !finished) {
        auto line = child.readLine();
        ASSERT_TRUE(line) << "mapper stopped early";
        consume(*line);
        frames_seen += line->rfind("frame ", 0) == 0;
      }
      if (kills % 4 == 1) {
        std::this_thread::sleep_for(std::chrono::microseconds(rng() % 30000));
      } else {
        // Aim: into the next frame's write transaction, or into its COMMIT.
        const std::string aim = kills % 4 == 2 ? "tx" : "commit";
        while (!finished) {
          auto line = child.readLine();
          ASSERT_TRUE(line) << "mapper stopped early";
          consume(*line);
          if (*line == aim) break;
        }
        if (aim == "tx") std::this_thread::sleep_for(std::chrono::microseconds(rng() % 2000));
      }
    }
    child.kill();
    child.wait();
    // Frames whose report was already written are committed, whatever the kill interrupted.
    while (auto line = child.readLine(1000)) consume(*line);
    if (finished) break;
    ++kills;
    if (!ready_seen) {
      ++in_startup;
    } else if (last_line == "tx") {
      ++in_transaction;
    } else if (last_line == "commit") {
      ++in_commit;
    } else {
      ++between_frames;
    }

    if (!std::filesystem::exists(killed)) continue;  // killed before the file was made
    ASSERT_EQ(integrityCheck(killed), "ok") << "after kill " << kills;
    const auto stored = storedFrames(killed);
    expectContiguous(stored);
    // The kill may land after a commit and before its report: at most one frame more.
    ASSERT_GE(std::int64_t(stored.size()), committed)
        << "a committed frame was lost, kill " << kills;
    ASSERT_LE(std::int64_t(stored.size()), committed + 1) << "kill " << kills;
    committed = static_cast<std::int64_t>(stored.size());
  }
  std::cout << kills << " kills: " << in_startup << " in start-up, " << between_frames
            << " between transactions, " << in_transaction << " inside a transaction, " << in_commit
            << " during COMMIT; " << committed << " of " << kFrames
            << " frames committed by then\n";
  EXPECT_EQ(kills, kKills) << "the sequence ended before every kill was made";
  EXPECT_GE(in_transaction + in_commit, 8);

  const auto last_run = runMapper(killed, killed_args);
  ASSERT_FALSE(last_run.empty());
  EXPECT_EQ(last_run.back(), "done");
  ASSERT_EQ(integrityCheck(killed), "ok");
  const auto actual = storedFrames(killed);
  ASSERT_EQ(actual.size(), expected.size());
  for (const auto& [index, want] : expected) {
    const StoredFrame& got = actual.at(index);
    SCOPED_TRACE("frame " + std::to_string(index));
    EXPECT_EQ(got.frame_id, want.frame_id);
    EXPECT_EQ(got.outcome, want.outcome);
    EXPECT_EQ(got.location, want.location);
    EXPECT_EQ(got.hypothesis, want.hypothesis);
    EXPECT_NEAR(got.posterior, want.posterior, 1e-6);
    EXPECT_NEAR(got.score, want.score, 1e-6);
    EXPECT_EQ(got.accepted, want.accepted);
  }
}

}  // namespace
}  // namespace placedb::testing
