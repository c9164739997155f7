// The engine's rooms include one another downwards only: the pipeline's steps (features,
// vocabulary, filter, memory, geometry) know nothing of the decision or of the map that drives
// them, and the rest of the engine reaches geometric verification through geometry/geometry.h.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

// What each room may include besides itself and the public headers (placedb/).
const std::map<std::string, std::set<std::string>>& allowedRooms() {
  static const std::map<std::string, std::set<std::string>> allowed = {
      {"api", {}},
      {"features", {}},
      {"vocabulary", {"features"}},
      {"filter", {}},
      // features/ is the floor: parallel_for.h and cpu_support.h (which SIMD loops may run).
      {"memory", {"features"}},
      {"geometry", {"features"}},
      {"decision", {"filter", "geometry"}},
      {"map", {"features", "vocabulary", "filter", "memory", "geometry", "decision", "api"}},
  };
  return allowed;
}

struct Include {
  std::string file;  // relative to engine/src
  std::string room;  // the including file's room
  std::string target;
};

std::vector<Include> engineIncludes(const fs::path& root) {
  static const std::regex quoted(R"(^\s*#\s*include\s*"([^"]+)\")");
  std::vector<Include> out;
  for (const auto& entry : fs::recursive_directory_iterator(root)) {
    if (!entry.is_regular_file()) continue;
    const std::string ext = entry.path().extension().string();
    if (ext != ".h" && ext != ".cpp") continue;
    const fs::path rel = fs::relative(entry.path(), root);
    std::ifstream in(entry.path());
    std::string line;
    std::smatch m;
    while (std::getline(in, line))
      if (std::regex_search(line, m, quoted))
        out.push_back({rel.generic_string(), rel.begin()->string(), m[1].str()});
  }
  return out;
}

std::string roomOf(const std::string& include) {
  const auto slash = include.find('/');
  return slash == std::string::npos ? std::string() : include.substr(0, slash);
}

TEST(Layering, EveryRoomIsKnown) {
  const fs::path root = PLACEDB_ENGINE_SOURCE_DIR;
  for (const auto& entry : fs::directory_iterator(root)) {
    if (entry.is_directory()) {
      EXPECT_TRUE(allowedRooms().count(entry.path().filename().string()))
          << entry.path() << " is a room this test does not place in the layers";
    }
  }
}

TEST(Layering, RoomsIncludeDownwardsOnly) {
  const auto includes = engineIncludes(PLACEDB_ENGINE_SOURCE_DIR);
  ASSERT_GT(includes.size(), 50u) << "no sources under " << PLACEDB_ENGINE_SOURCE_DIR;
  for (const Include& inc : includes) {
    const std::string target_room = roomOf(inc.target);
    if (target_room.empty() || target_room == "placedb" || target_room == inc.room) continue;
    const auto allowed = allowedRooms().find(inc.room);
    ASSERT_NE(allowed, allowedRooms().end()) << inc.file;
    EXPECT_TRUE(allowed->second.count(target_room))
        << inc.file << " (room " << inc.room << ") includes " << inc.target
        << ", a room it may not depend on";
  }
}

TEST(Layering, GeometryIsReachedThroughItsHeader) {
  for (const Include& inc : engineIncludes(PLACEDB_ENGINE_SOURCE_DIR)) {
    if (inc.room != "geometry" && roomOf(inc.target) == "geometry") {
      EXPECT_EQ(inc.target, "geometry/geometry.h") << inc.file;
    }
  }
}

}  // namespace
