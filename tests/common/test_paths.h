#pragma once
// Where tests find the shared data sets and a scratch folder of their own.
#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <signal.h>
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
// its own process, and fixtures share names: the process id keeps their folders apart. The
// folders of the same name that ended processes left are removed first: the last run's stays for
// a look, and repeated runs do not fill the disk (maps of every run piled up to tens of GB).
inline std::filesystem::path scratchDir(const std::string& test_name) {
  const auto root = std::filesystem::path(PLACEDB_TEST_BINARY_DIR) / "scratch";
  const std::string prefix = test_name + ".";
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(root, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string pid = name.substr(prefix.size());
    if (pid.find_first_not_of("0123456789") != std::string::npos || pid.size() > 9) continue;
    // Another process of the same name may still be using its folder: only an ended one's goes.
    if (::kill(static_cast<pid_t>(std::stol(pid)), 0) != 0 && errno == ESRCH)
      std::filesystem::remove_all(entry.path(), ec);
  }
  auto dir = root / (prefix + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace placedb::testing
