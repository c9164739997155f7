#pragma once
// One `placedb map` invocation: open (or create) the map, start or resume a session over the
// source, process frames until the end, --stop-after or Ctrl-C, log them, close cleanly.
//
// Resume rule: when the map's last session ran over the same source (canonical absolute paths)
// and either was interrupted (not closed cleanly) or stopped before the source's end (a clean
// close after --stop-after or Ctrl-C), that session continues with the first frame not yet
// processed; otherwise a new session begins. --new-session forces a new one.
#include <cstdint>
#include <optional>
#include <string>

#include "image_source.h"
#include "settings_input.h"

namespace placedb::cli {

struct MappingRequest {
  std::string map_path;
  std::string source;
  SourceOptions source_options;  // a bag's topic, a live source's rate cap
  std::string log_path;          // empty: no log
  SettingsInput settings;
  std::optional<std::int64_t> stop_after;
  bool new_session = false;
  bool quiet = false;  // no progress output, no line per accepted loop closure
};

struct MappingSummary {
  std::int64_t session_id = 0;
  bool resumed = false;
  std::int64_t first_index = 0;  // source index this run started from
  std::int64_t processed = 0;    // frames processed by this run
  std::int64_t unreadable = 0;
  std::int64_t bad = 0;            // frames recorded as bad (the unreadable ones among them)
  std::int64_t loop_closures = 0;  // frames whose loop-closure hypothesis was accepted
  std::int64_t locations_created = 0;
  std::int64_t dropped = 0;    // a live source's frames that arrived while the engine was busy
  bool interrupted = false;    // Ctrl-C / SIGTERM
  bool stopped_early = false;  // --stop-after
  bool reached_end = false;    // the source has no frame left
  double seconds = 0;
};

MappingSummary runMapping(const MappingRequest& request);

}  // namespace placedb::cli
