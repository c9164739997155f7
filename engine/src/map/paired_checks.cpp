#include "map/paired_checks.h"

#include <algorithm>
#include <utility>

#include "features/parallel_for.h"
#include "placedb/error.h"

namespace placedb {

PairedChecks::PairedChecks(std::vector<LocationId> order, int threads, Prepare prepare, Check check)
    : order_(std::move(order)),
      threads_(threads),
      prepare_(std::move(prepare)),
      check_(std::move(check)) {}

std::optional<LocationId> PairedChecks::nextAfter(LocationId candidate) const {
  auto it = std::find(order_.begin(), order_.end(), candidate);
  if (it == order_.end()) return std::nullopt;
  for (++it; it != order_.end(); ++it)
    if (!asked_.count(*it) && !ahead_.count(*it)) return *it;
  return std::nullopt;
}

std::optional<GeometricResult> PairedChecks::operator()(LocationId candidate) {
  const bool first = asked_.empty();
  asked_.insert(candidate);
  if (auto made = ahead_.extract(candidate)) return std::move(made.mapped());
  const std::optional<GeometricView> view = prepare_(candidate);
  if (!view) return std::nullopt;
  // The first candidate alone: when it passes, as on most frames of a revisit, nothing else is
  // checked, and a check made beside it would only have been waited for.
  const std::optional<LocationId> next =
      first || threads_ < 2 ? std::nullopt : nextAfter(candidate);
  // A damaged row read ahead is not kept: the candidate is read and checked again, and fails the
  // frame, only if chooseCandidate asks for it, as one by one. Any other failure is the map's
  // as a whole (a lost server, the disk), which the frame meets anyway: it goes on up at once.
  std::optional<GeometricView> next_view;
  if (next) {
    try {
      next_view = prepare_(*next);
      if (!next_view) ahead_.emplace(*next, std::nullopt);
    } catch (const Error& e) {
      if (e.code() != ErrorCode::kMapRefused) throw;
    }
  }
  if (!next_view) return check_(*view);
  GeometricResult results[2];
  bool next_checked = false;
  const GeometricView* views[2] = {&*view, &*next_view};
  parallelFor(2, threads_, [&](int i) {
    if (i == 0) {
      results[0] = check_(*views[0]);
      return;
    }
    try {
      results[1] = check_(*views[1]);
      next_checked = true;
    } catch (...) {
    }
  });
  if (next_checked) {
    ahead_.emplace(*next, std::move(results[1]));
    ++made_ahead_;
  }
  return std::move(results[0]);
}

}  // namespace placedb
