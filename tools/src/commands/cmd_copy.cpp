// placedb copy SRC DST: a whole map from one backend to another.
#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <memory>

#include "commands/commands.h"
#include "map_argument.h"
#include "placedb/error.h"
#include "placedb/storage/map_copy.h"
#include "placedb/storage/map_files.h"
#include "placedb/storage/map_store.h"

namespace placedb::cli {
namespace {

int runCopy(const std::string& from, const std::string& to) {
  namespace fs = std::filesystem;
  const std::string from_name = storage::mapDisplayName(from);
  const std::string to_name = storage::mapDisplayName(to);
  requireExistingMap(from);
  const bool to_file = !storage::isServerMap(to);
  std::error_code ec;
  if (to_file && fs::exists(to, ec)) {
    // An existing file is never opened for writing: it stays byte for byte as it was.
    if (!storage::isServerMap(from) && fs::equivalent(from, to, ec))
      throw Error(ErrorCode::kInvalidArgument,
                  fmt::format("copy: {} and {} are the same map", from_name, to_name));
    if (fs::file_size(to, ec) > 0 || ec)
      throw Error(ErrorCode::kInvalidArgument,
                  fmt::format("copy: {} exists; a copy is refused over another file (give a new "
                              "name, or delete it first)",
                              to_name));
  }
  if (!to_file && from_name == to_name)
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("copy: {} and {} are the same map", from_name, to_name));
  const auto source = storage::openMapStore(from, storage::OpenMode::kReadOnly);
  const bool created = to_file && !fs::exists(to, ec);
  try {
    const auto target = storage::openMapStore(to, storage::OpenMode::kReadWrite);
    storage::copyMap(*source, *target);
  } catch (...) {
    // Only a file this command made is deleted; a database keeps its (empty) tables.
    if (created) storage::removeMap(to);
    throw;
  }
  std::fputs(
      fmt::format("placedb: copied {} ({} sessions, {} frames, {} words) to {}\n", from_name,
                  source->sessions().size(), source->frameCount(), source->wordCount(), to_name)
          .c_str(),
      stderr);
  return 0;
}

}  // namespace

Command addCopyCommand(CLI::App& parent) {
  struct Request {
    std::string from, to;
  };
  auto request = std::make_shared<Request>();
  CLI::App* app = parent.add_subcommand("copy", "Copy a whole map to a file or to a server");
  app->footer(
      "Copy every session, frame, location, word, link and the engine's resume state of SRC\n"
      "into DST, as they are: mapping more frames on the copy (placedb map DST ...) decides\n"
      "exactly as on SRC. Either may be a file or a map on a PostgreSQL server\n"
      "(postgresql://...): a robot that mapped offline uploads its map to the fleet's server;\n"
      "a robot leaving the network takes the fleet's map with it as a file.\n\n"
      "SRC is opened read-only (a writer may be mapping into it: the copy is one consistent\n"
      "snapshot). DST must be new: a missing file, or a database without a placedb map (its\n"
      "tables are created) or with an empty one. An existing file or a map holding anything\n"
      "is refused (exit 2) and left as it was. The copy is one transaction: on any failure\n"
      "nothing is left in DST (a file this command created is deleted).\n\n"
      "Examples:\n"
      "  placedb copy run.placedb 'postgresql://robot@fleet-db/fleet'    # upload\n"
      "  placedb copy 'postgresql://robot@fleet-db/fleet' fleet.placedb  # take it along\n"
      "  placedb copy run.placedb backup.placedb                          # a file copy made\n"
      "                                                                   # while mapping runs");
  // Not mapArgument(): two URIs may carry two passwords, so each stays in its own URI here
  // and only mapDisplayName() of it is ever shown.
  app->add_option("SRC", request->from, "the map to copy: a file or a postgresql:// URI")
      ->required();
  app->add_option("DST", request->to, "the new map: a file or a postgresql:// URI")->required();
  return {app, [request]() { return runCopy(request->from, request->to); }};
}

}  // namespace placedb::cli
