#include "engine/closure_run.h"

#include <cstdlib>

namespace placedb {

std::optional<RunReach> reachOf(const ClosureRun& run, std::int64_t frame, std::int64_t session,
                                const RunSettings& settings) {
  const std::int64_t gap = frame - run.frame;
  if (run.anchor == 0 || run.session != session || gap < 1 || gap > settings.max_gap)
    return std::nullopt;
  if (gap == 1) return RunReach{settings.radius, 0};
  if (run.heading == 0) return std::nullopt;
  return RunReach{settings.radius + static_cast<int>(gap) - 1, run.heading};
}

ClosureRun anchorAt(const ClosureRun& run, LocationId location, std::int64_t frame,
                    std::int64_t session, bool continues, const RunSettings& settings) {
  const bool recent = run.anchor != 0 && run.session == session && frame - run.frame >= 1 &&
                      frame - run.frame <= settings.max_gap;
  ClosureRun next;
  next.anchor = location;
  next.frame = frame;
  next.session = session;
  next.first = continues ? run.first : location;
  next.heading = recent ? run.heading : 0;
  const std::int64_t moved = next.anchor - next.first;
  if (std::llabs(moved) > settings.radius) next.heading = moved > 0 ? 1 : -1;
  return next;
}

}  // namespace placedb
