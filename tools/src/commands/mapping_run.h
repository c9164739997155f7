#pragma once
// One `placedb map` invocation: open (or create) the map, start or resume a session over the
// source, process frames until the end, --stop-after or Ctrl-C, log them, close cleanly.
//
// Resume rule: when the map's last session ran over the same source (canonical absolute paths)
// and either was interrupted (not closed cleanly) or stopped before the source's end (a clean
// close after --stop-after or Ctrl-C), that session continues with the first frame not yet
// processed; otherwise a new session begins. A camera or stream never resumes (its frames are
// never the same twice); a ROS topic always does (it has no end: a clean close is a shutdown).
// --new-session forces a new one. On a fleet map (a server map with several writers) the session is
// the newest over the same source whose memory the map keeps: the main line's newest, or a side
// session of its own.
//
// A map on a server whose connection is lost mid-run (a server restart, the network): the run
// waits up to server_wait_s for it, reopens the map and resumes the session as a new run would,
// from the first frame the map does not hold; then kServerLost.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "placedb/map.h"
#include "settings_input.h"
#include "sources/image_source.h"

namespace placedb::cli {

struct MappingRequest {
  std::string map_path;
  std::string source;
  SourceOptions source_options;  // a bag's topic, a live source's rate cap
  std::string log_path;          // empty: no log
  SettingsInput settings;
  std::optional<std::int64_t> stop_after;
  bool new_session = false;
  bool quiet = false;  // no progress, start line or closure lines; the summary stays
  // A map on a server: how long to wait for the server when the connection is lost during the
  // run, before exiting with kServerLost (13). 0: at once.
  double server_wait_s = 60;
  // A source the caller opened (the ROS node's topic, ros/src/topic_source.h); `source` is then
  // its name in messages only. Null: runMapping opens `source`.
  std::shared_ptr<ImageSource> opened_source;
  // Called with each frame once it is committed and logged (the ROS node publishes it).
  std::function<void(const SourceFrame&, const FrameResult&)> on_frame;
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
  std::int64_t dropped = 0;     // a live source's frames that arrived while the engine was busy
  bool interrupted = false;     // Ctrl-C / SIGTERM / SIGHUP
  bool stopped_early = false;   // --stop-after
  bool reached_end = false;     // the source has no frame left
  std::string stalled;          // a live source that stopped sending: why ("" otherwise)
  bool live = false;            // a camera or stream: never resumed
  std::int64_t next_index = 0;  // the first frame of the source not mapped
  std::optional<std::int64_t> source_size;  // frames in the source, when known
  double seconds = 0;
};

// Why the run ended and what the next `placedb map` over the same source does: "end of source",
// or that it resumes at frame N (true only when it will), for the summary line.
std::string endOfRunText(const MappingSummary& summary);

MappingSummary runMapping(const MappingRequest& request);

}  // namespace placedb::cli
