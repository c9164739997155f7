#include "frame_names.h"

#include <fmt/format.h>

namespace placedb::cli {

std::string stampText(std::int64_t stamp_ns) {
  // Whole seconds and nanoseconds apart, so that no double rounds the nanoseconds away.
  const bool negative = stamp_ns < 0;
  const std::uint64_t magnitude =
      negative ? 0 - static_cast<std::uint64_t>(stamp_ns) : static_cast<std::uint64_t>(stamp_ns);
  return fmt::format("{}{}.{:09}", negative ? "-" : "", magnitude / 1000000000u,
                     magnitude % 1000000000u);
}

std::string frameName(std::int64_t session_id, std::int64_t source_index,
                      std::optional<std::int64_t> stamp_ns) {
  std::string name = fmt::format("{}:{}", session_id, source_index);
  if (stamp_ns) name += "@" + stampText(*stamp_ns);
  return name;
}

std::string frameName(const FrameRef& frame) {
  return frameName(frame.session_id, frame.source_index, frame.stamp_ns);
}

std::string frameNames(const std::vector<FrameRef>& frames) {
  std::string names;
  for (const auto& f : frames) names += (names.empty() ? "" : " ") + frameName(f);
  return names;
}

}  // namespace placedb::cli
