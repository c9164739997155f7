#pragma once
// What `placedb info` reports about a map, as one JSON object (the `--json` output), for the
// command line and the Python module alike.
#include <nlohmann/json.hpp>
#include <string>

namespace placedb::cli {

// Opens the map read-only and leaves it untouched. Throws placedb::Error(kIo) when the file is
// missing, and the storage errors of a refused map.
nlohmann::json inspectMap(const std::string& path);

}  // namespace placedb::cli
