#pragma once
// The files one map is made of: the SQLite database and the side files kept next to it under the
// same name. Every place that lists, checks or deletes a map's files asks here.
#include <string>
#include <vector>

namespace placedb::storage {

// The suffixes of a map's side files: SQLite's write-ahead log and its shared-memory index, a
// rollback journal (only while a non-WAL connection writes), and the writer lock.
const std::vector<std::string>& mapSideSuffixes();

// The side file with `suffix` (one of mapSideSuffixes()).
std::string mapSideFile(const std::string& map_path, const std::string& suffix);
std::string walFile(const std::string& map_path);
std::string lockFile(const std::string& map_path);

// The map and every side file, whether it exists or not.
std::vector<std::string> mapFiles(const std::string& map_path);

// Deletes the map and its side files (missing ones are fine). Throws placedb::Error(kIo) naming
// the file that could not be deleted. The map must not be open.
void removeMap(const std::string& map_path);

}  // namespace placedb::storage
