#pragma once
// What `placedb info` reports about a map, as one JSON object (the `--json` output), for the
// command line and the Python module alike.
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "placedb/options.h"

namespace placedb::cli {

// Opens the map read-only and leaves it untouched. Throws placedb::Error(kIo) when the file is
// missing, and the storage errors of a refused map.
nlohmann::json inspectMap(const std::string& path);

// The settings of the map's last session, read-only: what localising against the map needs
// (features extracted the same way). None when the map has no session yet.
std::optional<Options> lastSessionOptions(const std::string& path);

}  // namespace placedb::cli
