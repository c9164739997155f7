// Diagnostic: opens a map read-only and prints, for the given frames of a list, the stored
// locations most similar to each (eq. 5), to see where the best raw match lies against the
// ground truth without the filter's smoothing.
//
//   placedb_quality_probe MAP LIST FRAME...
#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "features/image_conversion.h"
#include "placedb/map.h"

int main(int argc, char** argv) {
  if (argc < 4) {
    fmt::print(stderr, "usage: {} MAP LIST FRAME...\n", argv[0]);
    return 2;
  }
  try {
    const std::filesystem::path list = argv[2];
    std::ifstream in(list);
    std::vector<std::string> frames;
    for (std::string line; std::getline(in, line);)
      if (!line.empty() && line[0] != '#') frames.push_back((list.parent_path() / line).string());
    auto map = placedb::Map::open(argv[1], placedb::Options(), placedb::Map::Mode::kLocalisation);
    for (int a = 3; a < argc; ++a) {
      const std::size_t index = std::stoul(argv[a]);
      const auto result = map->query(placedb::loadGreyImage(frames.at(index)), 8);
      fmt::print("frame {}:", index);
      for (const auto& m : result.matches) {
        std::string covered;
        for (const auto& f : m.frames)
          covered += (covered.empty() ? "" : "+") + std::to_string(f.source_index);
        fmt::print("  [{}] {:.3f}", covered, m.similarity);
      }
      fmt::print("\n");
    }
    return 0;
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 1;
  }
}
