#pragma once
// The view of the latest frame merged into a location. STM merging keeps the keypoints of a
// location's first frame only (its signature, its stored view), so a location that stands for
// frames a..b is compared as seen from a. A revisit that passes b then agrees better with the
// next location's view, one frame ahead of b, than with a, and the closure names the frame after
// the one the camera is at (the +1 offsets of bench/quality/README.md). Keeping every merged
// frame's keypoints would grow without bound where the camera stands still (a frame a tick, each
// merged); the latest one alone bounds a location at two views, and covers both ends of the
// locations a moving camera makes (two or three frames each on the walks of bench/quality).
//
// Stored in engine_state under storage::locationLatestViewKey, replaced at each merge: the
// frame's id (int64), the keypoint count n (uint32), n times x, y (float32) and word (int64, -1
// for a word the merge discarded), then the keypoints' own descriptors as encodeDescriptors()
// writes them; little-endian.
#include <cstdint>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "geometry/keypoint_cache.h"

namespace placedb {

struct LatestView {
  std::int64_t frame_id = 0;
  CachedKeypoints keypoints;  // with codes whenever the view holds a keypoint
};

std::vector<std::uint8_t> encodeLatestView(std::int64_t frame_id,
                                           const std::vector<cv::Point2f>& points,
                                           const std::vector<std::int64_t>& words,
                                           const std::vector<std::uint8_t>& descriptors);
// Nothing when the bytes are not such a view of descriptors of `dim` values.
std::optional<LatestView> decodeLatestView(const std::vector<std::uint8_t>& bytes, int dim);

}  // namespace placedb
