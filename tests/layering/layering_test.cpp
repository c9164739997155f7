// Rooms include one another downwards only, in each of the three components with rooms:
// - engine/src/: the pipeline's steps (features, vocabulary, filter, memory, geometry) know
//   nothing of the decision or of the map that drives them, and the rest of the engine reaches
//   geometric verification through geometry/geometry.h;
// - storage/src/: the shared top (interface, records, checksums, migrations, copy, the check's
//   report) is the floor; sqlite/ and postgres/ stand on it and neither includes the other;
// - tools/src/: the plumbing at the top is the floor, then sources/, report/, commands/.
// An include is resolved as the compiler does (beside the including file, then from src/), so
// "../postgres/x.h" or a bare "x.h" beside it is caught as well as "postgres/x.h". Besides, no
// folder holds more than 20 .cpp files and no two files include each other, even through others.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <regex>
#include <set>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

// What each room may include besides itself, the public headers (placedb/) and other components.
// "" is the top of src/: the files directly in it.
using Rooms = std::map<std::string, std::set<std::string>>;

const Rooms& engineRooms() {
  static const Rooms allowed = {
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

const Rooms& storageRooms() {
  // The top picks a backend through backends.h, which it declares and the backends define.
  static const Rooms allowed = {{"", {}}, {"sqlite", {""}}, {"postgres", {""}}};
  return allowed;
}

const Rooms& toolsRooms() {
  static const Rooms allowed = {
      {"", {}},
      {"sources", {""}},
      {"report", {"", "sources"}},
      {"commands", {"", "sources", "report"}},
  };
  return allowed;
}

struct Component {
  const char* name;
  fs::path root;
  const Rooms* rooms;
};

std::vector<Component> components() {
  return {{"engine", PLACEDB_ENGINE_SOURCE_DIR, &engineRooms()},
          {"storage", PLACEDB_STORAGE_SOURCE_DIR, &storageRooms()},
          {"tools", PLACEDB_TOOLS_SOURCE_DIR, &toolsRooms()}};
}

bool isSource(const fs::path& path) {
  const std::string ext = path.extension().string();
  return ext == ".h" || ext == ".cpp";
}

// The room of a file under root: its first folder, or "" for a file at the top.
std::string roomOf(const fs::path& rel) {
  return std::distance(rel.begin(), rel.end()) > 1 ? rel.begin()->string() : std::string();
}

struct Include {
  fs::path file;                   // relative to the component's root
  std::string target;              // as written
  std::optional<fs::path> inside;  // the file it names under root, when it is one
};

std::vector<Include> includesUnder(const fs::path& root) {
  static const std::regex quoted(R"(^\s*#\s*include\s*"([^"]+)\")");
  std::vector<Include> out;
  for (const auto& entry : fs::recursive_directory_iterator(root)) {
    if (!entry.is_regular_file() || !isSource(entry.path())) continue;
    const fs::path rel = fs::relative(entry.path(), root);
    std::ifstream in(entry.path());
    std::string line;
    std::smatch m;
    while (std::getline(in, line)) {
      if (!std::regex_search(line, m, quoted)) continue;
      Include inc{rel, m[1].str(), std::nullopt};
      for (const fs::path& candidate :
           {entry.path().parent_path() / inc.target, root / inc.target}) {
        if (fs::is_regular_file(candidate)) {
          inc.inside = fs::relative(fs::weakly_canonical(candidate), fs::weakly_canonical(root));
          break;
        }
      }
      out.push_back(inc);
    }
  }
  return out;
}

// One line per include that goes where its room may not.
std::vector<std::string> layeringViolations(const fs::path& root, const Rooms& rooms) {
  std::vector<std::string> out;
  for (const Include& inc : includesUnder(root)) {
    if (!inc.inside) continue;
    const std::string from = roomOf(inc.file), to = roomOf(*inc.inside);
    if (from == to) continue;
    const auto allowed = rooms.find(from);
    if (allowed == rooms.end()) {
      out.push_back(inc.file.generic_string() + " is in a room the test does not place");
    } else if (!allowed->second.count(to)) {
      out.push_back(inc.file.generic_string() + " (room '" + from + "') includes " + inc.target +
                    " (room '" + to + "'), a room it may not depend on");
    }
  }
  return out;
}

// A cycle of includes between files under root, "a -> b -> a", or "" when there is none.
std::string includeCycle(const fs::path& root) {
  std::map<std::string, std::set<std::string>> edges;
  for (const Include& inc : includesUnder(root))
    if (inc.inside) edges[inc.file.generic_string()].insert(inc.inside->generic_string());
  std::map<std::string, int> state;  // 1: on the path, 2: done
  std::vector<std::string> path;
  std::string cycle;
  std::function<bool(const std::string&)> visit = [&](const std::string& node) {
    state[node] = 1;
    path.push_back(node);
    for (const std::string& next : edges[node]) {
      if (state[next] == 1) {
        for (auto it = std::find(path.begin(), path.end(), next); it != path.end(); ++it)
          cycle += *it + " -> ";
        cycle += next;
        return true;
      }
      if (state[next] == 0 && visit(next)) return true;
    }
    path.pop_back();
    state[node] = 2;
    return false;
  };
  std::vector<std::string> nodes;
  for (const auto& [node, targets] : edges) nodes.push_back(node);
  for (const std::string& node : nodes)
    if (state[node] == 0 && visit(node)) return cycle;
  return "";
}

// True when the rooms' allowances go one way only (no room may reach back to itself).
bool roomsFormLayers(const Rooms& rooms) {
  std::function<bool(const std::string&, std::set<std::string>&)> reaches =
      [&](const std::string& room, std::set<std::string>& seen) {
        const auto it = rooms.find(room);
        if (it == rooms.end()) return true;
        for (const std::string& below : it->second) {
          if (seen.count(below)) return false;
          seen.insert(below);
          if (!reaches(below, seen)) return false;
          seen.erase(below);
        }
        return true;
      };
  for (const auto& [room, below] : rooms) {
    std::set<std::string> seen{room};
    if (!reaches(room, seen)) return false;
  }
  return true;
}

TEST(Layering, EveryRoomIsKnown) {
  for (const Component& c : components()) {
    for (const auto& entry : fs::directory_iterator(c.root)) {
      if (entry.is_directory()) {
        EXPECT_TRUE(c.rooms->count(entry.path().filename().string()))
            << entry.path() << " is a room this test does not place in " << c.name << "'s layers";
      }
    }
  }
}

TEST(Layering, RoomsFormLayers) {
  for (const Component& c : components()) EXPECT_TRUE(roomsFormLayers(*c.rooms)) << c.name;
}

TEST(Layering, RoomsIncludeDownwardsOnly) {
  for (const Component& c : components()) {
    ASSERT_GT(includesUnder(c.root).size(), 50u) << "no sources under " << c.root;
    for (const std::string& violation : layeringViolations(c.root, *c.rooms))
      ADD_FAILURE() << c.name << "/src/" << violation;
  }
}

TEST(Layering, GeometryIsReachedThroughItsHeader) {
  for (const Include& inc : includesUnder(PLACEDB_ENGINE_SOURCE_DIR)) {
    if (inc.inside && roomOf(inc.file) != "geometry" && roomOf(*inc.inside) == "geometry") {
      EXPECT_EQ(inc.inside->generic_string(), "geometry/geometry.h") << inc.file;
    }
  }
}

TEST(Layering, NoFolderHoldsMoreThan20CppFiles) {
  for (const Component& c : components()) {
    std::map<fs::path, int> cpp_files;
    for (const auto& entry : fs::recursive_directory_iterator(c.root))
      if (entry.is_regular_file() && entry.path().extension() == ".cpp")
        ++cpp_files[entry.path().parent_path()];
    for (const auto& [folder, count] : cpp_files) EXPECT_LE(count, 20) << folder;
  }
}

TEST(Layering, NoIncludeCycleBetweenFiles) {
  for (const Component& c : components()) EXPECT_EQ(includeCycle(c.root), "") << c.name;
}

// The checks above on a scratch tree: they must catch what they are for.
class ScratchTree : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() /
            ("placedb_layering_" +
             std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(root_);
  }
  void TearDown() override { fs::remove_all(root_); }
  void write(const std::string& rel, const std::string& text) {
    fs::create_directories((root_ / rel).parent_path());
    std::ofstream(root_ / rel) << text;
  }
  fs::path root_;
};

TEST_F(ScratchTree, OneBackendIncludingTheOtherFails) {
  write("row_checksums.h", "");
  write("sqlite/database.h", "#include \"row_checksums.h\"\n");
  write("postgres/pg_connection.h", "#include \"row_checksums.h\"\n");
  EXPECT_TRUE(layeringViolations(root_, storageRooms()).empty());
  write("postgres/pg_map_store.cpp", "#include \"sqlite/database.h\"\n");
  EXPECT_EQ(layeringViolations(root_, storageRooms()).size(), 1u);
  // Reached by a path relative to the including file, too.
  write("sqlite/sqlite_map_store.cpp", "#include \"../postgres/pg_connection.h\"\n");
  EXPECT_EQ(layeringViolations(root_, storageRooms()).size(), 2u);
  // The shared top is below both backends.
  write("map_store.cpp", "#include \"sqlite/database.h\"\n");
  EXPECT_EQ(layeringViolations(root_, storageRooms()).size(), 3u);
}

TEST_F(ScratchTree, ALowerRoomIncludingAHigherOneFails) {
  write("exit_codes.h", "");
  write("sources/image_source.h", "#include \"exit_codes.h\"\n");
  write("report/report.cpp", "#include \"sources/image_source.h\"\n");
  write("commands/cmd_report.cpp", "#include \"report/report.h\"\n");
  write("report/report.h", "");
  EXPECT_TRUE(layeringViolations(root_, toolsRooms()).empty());
  write("sources/live_source.cpp", "#include \"report/report.h\"\n");
  write("exit_codes.cpp", "#include \"commands/commands.h\"\n");
  write("commands/commands.h", "");
  EXPECT_EQ(layeringViolations(root_, toolsRooms()).size(), 2u);
}

TEST_F(ScratchTree, AnIncludeCycleIsFound) {
  write("a.h", "#include \"b.h\"\n");
  write("b.h", "#include \"sub/c.h\"\n");
  write("sub/c.h", "");
  EXPECT_EQ(includeCycle(root_), "");
  write("sub/c.h", "#include \"a.h\"\n");
  EXPECT_NE(includeCycle(root_), "");
}

TEST(Layering, RoomsThatReachBackAreNotLayers) {
  EXPECT_FALSE(roomsFormLayers({{"", {"sqlite"}}, {"sqlite", {""}}}));
  EXPECT_TRUE(roomsFormLayers(toolsRooms()));
}

}  // namespace
