#pragma once
// How placedb names a frame to a person, the same in every message, page and export:
// SESSION:INDEX (the index into that session's source, from 0), followed by @SECONDS when the
// source gave the frame a stamp (a bag message's header.stamp: seconds since the epoch, nine
// decimals, as ROS prints a time): "2:45" or "2:45@1317384506.123456789".
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "placedb/map.h"

namespace placedb::cli {

// "1317384506.123456789" for 1317384506123456789 ns; negative stamps keep their sign.
std::string stampText(std::int64_t stamp_ns);

std::string frameName(std::int64_t session_id, std::int64_t source_index,
                      std::optional<std::int64_t> stamp_ns = std::nullopt);
std::string frameName(const FrameRef& frame);

// "1:10 1:11" for the frames of a location.
std::string frameNames(const std::vector<FrameRef>& frames);

}  // namespace placedb::cli
