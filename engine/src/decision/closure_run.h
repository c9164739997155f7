#pragma once
// Loop closures come in runs: while the camera retraces a path, each frame's place lies a link or
// two along the traversal from the place of the frame before. A run's anchor is its newest closure
// that passed the geometric check on its own; the WM locations the anchor reaches are checked as
// candidates too and pass a relaxed rule (temporal_* in options.h, map_verify.cpp).
//
// Reach. The frame right after the anchor reaches temporal_radius links either way: between two
// frames the best-matching place jitters by a link or two. Later frames, up to temporal_max_gap
// after the anchor, bridge a stretch where no closure passes on its own (blur, a passing car):
// the camera has moved on by then, so they reach ahead only, temporal_radius + gap - 1 links in
// the run's heading, and only a run with a heading reaches that far. Behind the anchor lies the
// failure that kept temporal acceptances from anchoring: chains that fall behind the camera drift
// back along the graph, a few places at a time, until they close the loop with the wrong place.
//
// Heading. The anchor's side of the run's first anchor along the location ids, which follow the
// traversal of their session, once the two lie more than temporal_radius apart (jitter has no
// heading). A closure that passes outside the current reach starts a new run: a jump to another
// visit of the place, or a few places on. When it comes within temporal_max_gap frames of the
// last anchor the new run keeps the old one's heading, since the camera still moves the same
// way and the visits of one street run the same way on these sequences; after a longer break
// it starts without one.
//
// End. A frame whose agreement with a place within the run's reach passes the check but shares
// only an object of the frame's scene (scene_extent.h) ends the run: the camera has turned off
// the route the run follows, and the relaxed rule has no revisit left to lean on
// (temporal_end_on_object; map_process.cpp).
#include <cstdint>
#include <optional>

#include "filter/signature.h"
#include "placedb/options.h"

namespace placedb {

struct ClosureRun {
  LocationId anchor = 0;     // newest closure that passed on its own, 0 = none
  std::int64_t frame = 0;    // the frame that accepted it
  std::int64_t session = 0;  // and that frame's session
  LocationId first = 0;      // the run's first anchor
  int heading = 0;           // +1 towards higher location ids, -1 towards lower ones, 0 unknown
};

struct RunSettings {
  int radius = Options().temporal_radius;
  int max_gap = Options().temporal_max_gap;
};

// Which locations continue a run at a frame: those within `links` neighbour links of the anchor,
// on the `heading` side of it (0: either side).
struct RunReach {
  int links = 0;
  int heading = 0;
  bool admits(LocationId anchor, LocationId id) const { return (id - anchor) * heading >= 0; }
};

// Nothing when the frame continues no run: none yet, another session, too many frames later, or
// more than one frame later in a run without a heading.
std::optional<RunReach> reachOf(const ClosureRun& run, std::int64_t frame, std::int64_t session,
                                const RunSettings& settings);

// The run after `location` passed on its own at `frame`; `continues` says whether it lay within
// the reach of the run before.
ClosureRun anchorAt(const ClosureRun& run, LocationId location, std::int64_t frame,
                    std::int64_t session, bool continues, const RunSettings& settings);

}  // namespace placedb
