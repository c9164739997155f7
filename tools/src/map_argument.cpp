#include "map_argument.h"

#include <fmt/format.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string_view>

#include "placedb/error.h"
#include "placedb/storage/map_store.h"

namespace placedb::cli {
namespace {

// Overwrites the password of the server URI at `uri` (up to its end, a NUL) with 'x's.
void hideUriPassword(char* uri) {
  const std::size_t size = std::strlen(uri);
  const auto hide = [uri](std::size_t from, std::size_t to) {
    for (std::size_t i = from; i < to; ++i) uri[i] = 'x';
  };
  const std::string_view text(uri, size);
  const std::size_t authority = text.find("://") + 3;
  std::size_t authority_end = text.find_first_of("/?#", authority);
  if (authority_end == std::string_view::npos) authority_end = size;
  const std::size_t at = text.rfind('@', authority_end);
  if (at != std::string_view::npos && at >= authority) {
    const std::size_t colon = text.find(':', authority);
    if (colon != std::string_view::npos && colon < at) hide(colon + 1, at);
  }
  const std::size_t query = text.find('?');
  for (std::size_t start = query == std::string_view::npos ? size : query + 1; start < size;) {
    std::size_t end = text.find('&', start);
    if (end == std::string_view::npos) end = size;
    if (text.compare(start, 9, "password=") == 0) hide(start + 9, end);
    start = end + 1;
  }
}

}  // namespace

void hidePasswordsInArguments(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string_view argument(argv[i]);
    for (const char* scheme : {"postgresql://", "postgres://"}) {
      const std::size_t at = argument.find(scheme);
      if (at != std::string_view::npos && (at == 0 || argument[at - 1] == '=')) {
        hideUriPassword(argv[i] + at);
        break;
      }
    }
  }
}

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
