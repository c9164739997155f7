#include "decision/closure_run.h"

#include <cstdlib>

namespace placedb {
namespace {

// Whether `frame` of `session` comes within the gap after the run's anchor.
bool withinGap(const ClosureRun& run, std::int64_t frame, std::int64_t session,
               const RunSettings& settings) {
  const std::int64_t gap = frame - run.frame;
  return run.anchor != 0 && run.session == session && gap >= 1 && gap <= settings.max_gap;
}

}  // namespace

std::optional<RunReach> reachOf(const ClosureRun& run, std::int64_t frame, std::int64_t session,
                                const RunSettings& settings) {
  if (!withinGap(run, frame, session, settings)) return std::nullopt;
  const std::int64_t gap = frame - run.frame;
  if (gap == 1) return RunReach{settings.radius, 0};
  if (run.heading == 0) return std::nullopt;
  return RunReach{settings.radius + static_cast<int>(gap) - 1, run.heading};
}

ClosureRun anchorAt(const ClosureRun& run, LocationId location, std::int64_t frame,
                    std::int64_t session, bool continues, const RunSettings& settings) {
  ClosureRun next;
  next.anchor = location;
  next.frame = frame;
  next.session = session;
  next.first = continues ? run.first : location;
  next.heading = withinGap(run, frame, session, settings) ? run.heading : 0;
  const std::int64_t moved = next.anchor - next.first;
  if (std::llabs(moved) > settings.radius) next.heading = moved > 0 ? 1 : -1;
  return next;
}

}  // namespace placedb
