#pragma once
// Where tests find the shared data sets and a scratch folder of their own.
#include <cstdlib>
#include <filesystem>
#include <string>

#include <unistd.h>

namespace placedb::testing {

// PLACEDB_DATASETS overrides the folder fixed at configure time.
inline std::filesystem::path datasetsDir() {
  if (const char* env = std::getenv("PLACEDB_DATASETS")) return env;
  return PLACEDB_DATASETS_DIR;
}

// Empty when the data set is absent; callers GTEST_SKIP() with the path in the message.
inline std::filesystem::path dataset(const std::string& name) {
  auto dir = datasetsDir() / name;
  return std::filesystem::exists(dir / "frames.txt") ? dir : std::filesystem::path();
}

// A fresh, empty folder under the build tree for one test. ctest runs tests in parallel, each in
// its own process, and fixtures share names: the process id keeps their folders apart.
inline std::filesystem::path scratchDir(const std::string& test_name) {
  auto dir = std::filesystem::path(PLACEDB_TEST_BINARY_DIR) / "scratch" /
             (test_name + "." + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace placedb::testing
