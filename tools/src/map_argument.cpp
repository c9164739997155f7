#include "map_argument.h"

#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>

#include "placedb/error.h"
#include "placedb/storage/map_store.h"

namespace placedb::cli {
namespace {

// libpq decodes %XX in a URI; PGPASSWORD is taken as it is.
std::string percentDecoded(const std::string& text) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '%' && i + 2 < text.size() &&
        std::isxdigit(static_cast<unsigned char>(text[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(text[i + 2]))) {
      out.push_back(static_cast<char>(std::stoi(text.substr(i + 1, 2), nullptr, 16)));
      i += 2;
    } else {
      out.push_back(text[i]);
    }
  }
  return out;
}

// The password a URI gives, if any: password=... wins over user:password@, as in libpq.
std::string passwordOf(const std::string& uri) {
  const std::size_t query = uri.find('?');
  if (query != std::string::npos) {
    std::size_t start = query + 1;
    while (start < uri.size()) {
      std::size_t end = uri.find('&', start);
      if (end == std::string::npos) end = uri.size();
      if (uri.compare(start, 9, "password=") == 0)
        return percentDecoded(uri.substr(start + 9, end - start - 9));
      start = end + 1;
    }
  }
  const std::size_t authority = uri.find("://") + 3;
  std::size_t end = uri.find_first_of("/?#", authority);
  if (end == std::string::npos) end = uri.size();
  const std::size_t at = uri.rfind('@', end);
  if (at == std::string::npos || at < authority) return {};
  const std::size_t colon = uri.find(':', authority);
  if (colon == std::string::npos || colon > at) return {};
  return percentDecoded(uri.substr(colon + 1, at - colon - 1));
}

}  // namespace

CLI::Validator mapArgument() {
  return CLI::Validator(
      [](std::string& map) {
        if (!storage::isServerMap(map)) return std::string();
        const std::string password = passwordOf(map);
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
