#pragma once
// The map is the record of a run, the frame log its copy: a run stopped between a frame's commit
// and its log row (a kill, a lost server, a full disk) leaves a frame the map holds and the log
// lacks. A resume writes such rows back, rebuilt from the map's frame and hypothesis rows.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "placedb/map.h"

namespace placedb::cli {

// The frames of `session` that the map at `map_path` holds with a source index above `after`
// (every one when none) and below `before`, by source index: what the map keeps of each (its
// outcome, location, statistics, stage times and stamp; its hypothesis and the frames of that
// hypothesis' location as they stood when the frame was committed). Counters the map does not
// keep (tier moves, the geometric check's figures) are 0.
std::vector<FrameResult> framesFromMap(const std::string& map_path, std::int64_t session,
                                       std::optional<std::int64_t> after, std::int64_t before);

}  // namespace placedb::cli
