#pragma once
// Commands that read a map and write a file refuse an output that is the map, or one of its side
// files, under any name (./MAP, dir/../MAP, a symbolic link): writing it would destroy the map.
#include <string>

namespace placedb::cli {

// Throws Error(kInvalidArgument) naming `command`, the output and the map file it is.
void refuseMapAsOutput(const std::string& command, const std::string& map_path,
                       const std::string& output);

}  // namespace placedb::cli
