// A test's scratch folder (test_paths.h): fresh for each run, and the folders that ended runs of
// the same name left are gone, while a running process's stay.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include <sys/wait.h>
#include <unistd.h>

#include "test_paths.h"

namespace placedb::testing {
namespace {

namespace fs = std::filesystem;

TEST(ScratchDir, FoldersOfEndedRunsGoThoseOfLiveOnesStay) {
  const fs::path root = fs::path(PLACEDB_TEST_BINARY_DIR) / "scratch";
  const pid_t child = ::fork();  // a process that has ended: a child exited and reaped
  if (child == 0) ::_exit(0);
  ASSERT_GT(child, 0);
  ::waitpid(child, nullptr, 0);
  const fs::path ended = root / ("ScratchProbe." + std::to_string(child));
  const fs::path live = root / ("ScratchProbe." + std::to_string(::getppid()));
  const fs::path other = root / ("ScratchProbeOther." + std::to_string(child));
  for (const fs::path& d : {ended, live, other}) fs::create_directories(d / "map");

  const fs::path mine = scratchDir("ScratchProbe");
  EXPECT_FALSE(fs::exists(ended));
  EXPECT_TRUE(fs::exists(live)) << "a running process may still use it";
  EXPECT_TRUE(fs::exists(other)) << "another test's name";
  EXPECT_TRUE(fs::is_empty(mine));
  fs::remove_all(live);
  fs::remove_all(other);
}

}  // namespace
}  // namespace placedb::testing
