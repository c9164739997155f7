#include "output_guard.h"

#include <fmt/format.h>

#include <filesystem>
#include <system_error>

#include "placedb/error.h"
#include "placedb/storage/map_files.h"
#include "placedb/storage/map_store.h"

namespace placedb::cli {

void refuseMapAsOutput(const std::string& command, const std::string& map_path,
                       const std::string& output) {
  namespace fs = std::filesystem;
  if (storage::isServerMap(map_path)) return;  // no file of the map can be an output
  std::error_code ec;
  const fs::path canonical_output = fs::weakly_canonical(output, ec);
  for (const auto& part : storage::mapFiles(map_path)) {
    std::error_code part_ec;
    // Existing files are compared by identity (a link or a hard link is the file); a side file
    // that is not there yet by the path it would have.
    const bool same = fs::exists(part, part_ec) && fs::exists(output, part_ec)
                          ? fs::equivalent(part, output, part_ec)
                          : fs::weakly_canonical(part, part_ec) == canonical_output;
    if (same && !part_ec)
      throw Error(
          ErrorCode::kInvalidArgument,
          fmt::format("{}: output {} is the map {} (or one of its files): give another file",
                      command, output, part));
  }
}

}  // namespace placedb::cli
