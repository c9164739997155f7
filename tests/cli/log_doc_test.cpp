// The per-frame log is documented in the project, in one table with the same words as the code
// (docs/log.md): every column FrameLogWriter writes, in its order, and no other.
#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <string>
#include <vector>

#include "frame_log.h"

namespace placedb::cli {
namespace {

TEST(LogDoc, TheTableListsTheColumnsTheCodeWrites) {
  std::ifstream page(std::string(PLACEDB_SOURCE_DIR) + "/docs/log.md");
  ASSERT_TRUE(page) << "docs/log.md is missing";
  // The first table of the page: rows "| `column` | meaning |".
  const std::regex row("^\\| `([a-z_]+)` \\| (.+) \\|$");
  std::vector<std::string> documented;
  bool in_table = false;
  for (std::string line; std::getline(page, line);) {
    std::smatch m;
    if (std::regex_match(line, m, row)) {
      in_table = true;
      documented.push_back(m[1]);
      EXPECT_GT(m[2].length(), 10u) << "column " << m[1] << " needs a meaning";
    } else if (in_table && line.rfind("|", 0) != 0) {
      break;
    }
  }
  EXPECT_EQ(documented, FrameLogWriter::columns());
}

}  // namespace
}  // namespace placedb::cli
