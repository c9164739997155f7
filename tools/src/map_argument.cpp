#include "map_argument.h"

#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>

#include "placedb/error.h"
#include "placedb/storage/map_store.h"

namespace placedb::cli {

CLI::Validator mapArgument() {
  return CLI::Validator(
      [](std::string& map) {
        if (!storage::isServerMap(map)) return std::string();
        const std::string password = storage::mapPassword(map);
        if (!password.empty()) {
          ::setenv("PGPASSWORD", password.c_str(), 1);
          map = storage::mapDisplayName(map);
        }
        return std::string();
      },
      "", "map");
}

void requireExistingMap(const std::string& map) {
  if (storage::isServerMap(map)) return;
  if (!std::filesystem::exists(map))
    throw Error(ErrorCode::kIo, fmt::format("map {} does not exist", map));
}

bool mapFileIsNew(const std::string& map) {
  if (storage::isServerMap(map)) return false;
  std::error_code ec;
  return !std::filesystem::exists(map, ec) || std::filesystem::file_size(map, ec) == 0;
}

}  // namespace placedb::cli
