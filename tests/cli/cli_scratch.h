#pragma once
// What the refusal and fault tests of the command line share: a small synthetic sequence of the
// calling test's own, file bytes, and a tiny tmpfs to fill up.
#include <gtest/gtest.h>
#include <sys/mount.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "cli_test_support.h"
#include "synthetic/synthetic_sequence.h"

namespace placedb::testing {

// `frames` synthetic frames (images/ and frames.txt) in a folder of the calling test's own.
inline std::filesystem::path smallSequence(int frames) {
  const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
  auto dir = scratchDir(std::string(test->test_suite_name()) + "_" + test->name() + "_seq");
  synthetic::SyntheticOptions options;
  options.frames = frames;
  options.width = 240;
  options.height = 180;
  synthetic::writeSequence(synthetic::SyntheticSequence(options), dir);
  return dir;
}

inline std::string bytesOf(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// A tmpfs of `size` (mount(8) syntax) at `where`; mounted() is false without CAP_SYS_ADMIN.
class TinyDisk {
 public:
  TinyDisk(const std::filesystem::path& where, const std::string& size) : where_(where) {
    std::filesystem::create_directories(where);
    mounted_ =
        ::mount("placedb-cli-test", where.c_str(), "tmpfs", 0, ("size=" + size).c_str()) == 0;
  }
  ~TinyDisk() {
    if (mounted_) ::umount2(where_.c_str(), MNT_DETACH);
  }
  TinyDisk(const TinyDisk&) = delete;
  TinyDisk& operator=(const TinyDisk&) = delete;
  bool mounted() const { return mounted_; }
  bool resize(const std::string& size) {
    return ::mount("placedb-cli-test", where_.c_str(), "tmpfs", MS_REMOUNT,
                   ("size=" + size).c_str()) == 0;
  }

 private:
  std::filesystem::path where_;
  bool mounted_ = false;
};

// Every row of a CSV file has the header's number of fields, and the file ends with a newline.
inline void expectWholeRows(const std::filesystem::path& csv) {
  const std::string text = bytesOf(csv);
  ASSERT_FALSE(text.empty());
  EXPECT_EQ(text.back(), '\n') << csv << " ends inside a row";
  auto rows = lines(text);
  const auto columns = cli::splitCsvLine(rows.front()).size();
  for (std::size_t i = 1; i < rows.size(); ++i)
    EXPECT_EQ(cli::splitCsvLine(rows[i]).size(), columns) << csv << " row " << i << ": " << rows[i];
}

}  // namespace placedb::testing
