#include "placedb/storage/map_files.h"

#include <algorithm>
#include <filesystem>

#include "placedb/error.h"

namespace placedb::storage {

const std::vector<std::string>& mapSideSuffixes() {
  static const std::vector<std::string> kSuffixes = {"-wal", "-shm", "-journal", "-lock"};
  return kSuffixes;
}

std::string mapSideFile(const std::string& map_path, const std::string& suffix) {
  return map_path + suffix;
}

std::string walFile(const std::string& map_path) { return mapSideFile(map_path, "-wal"); }

std::string lockFile(const std::string& map_path) { return mapSideFile(map_path, "-lock"); }

std::vector<std::string> mapFiles(const std::string& map_path) {
  std::vector<std::string> files{map_path};
  for (const auto& suffix : mapSideSuffixes()) files.push_back(mapSideFile(map_path, suffix));
  return files;
}

void removeMap(const std::string& map_path) {
  // Side files first: a map file left without its log is still a map, a log without its map is
  // litter that would be replayed into the next map made under this name.
  std::vector<std::string> files = mapFiles(map_path);
  std::rotate(files.begin(), files.begin() + 1, files.end());
  for (const auto& file : files) {
    std::error_code error;
    std::filesystem::remove(file, error);
    if (error) throw Error(ErrorCode::kIo, "cannot delete " + file + ": " + error.message());
  }
}

}  // namespace placedb::storage
