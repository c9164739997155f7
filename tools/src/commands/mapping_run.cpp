#include "commands/mapping_run.h"
#include "map_argument.h"

#include <fmt/format.h>

#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <thread>

#include "exit_codes.h"
#include "frame_log.h"
#include "frame_names.h"
#include "interrupt.h"
#include "log_recovery.h"
#include "placedb/map.h"
#include "placedb/storage/map_store.h"
#include "progress.h"
#include "sources/image_source.h"

namespace placedb::cli {
namespace {

// A camera, a stream or a ROS topic does not wait for the engine.
bool dropsFrames(const ImageSource& source) {
  return source.kind() == "live" || source.kind() == "topic";
}

bool sameSource(const std::string& stored, const std::string& canonical) {
  if (stored == canonical) return true;  // also a name that is not a path (a ROS topic's)
  std::error_code ec;
  auto resolved = std::filesystem::weakly_canonical(stored, ec);
  return (ec ? std::filesystem::path(stored) : resolved).string() == canonical;
}

// Where a resumed session continues, and the settings it keeps.
struct ResumePoint {
  std::int64_t session_id = 0;
  std::int64_t first_index = 0;
  std::map<std::string, std::string> settings;
};

// The resume rule of mapping_run.h for the map's last session.
std::optional<std::int64_t> resumeIndex(const storage::SessionRecord& last,
                                        std::optional<std::int64_t> last_index,
                                        const ImageSource& source) {
  if (source.kind() == "live" || !sameSource(last.source, source.canonicalPath()))
    return std::nullopt;  // a camera's frames are never the same twice
  const std::int64_t next = last_index ? *last_index + 1 : 0;
  if (last.clean_close && source.kind() != "topic") {
    // A source of unknown length cannot tell whether it was finished: treat it as finished.
    auto size = source.size();
    if (!size || next >= *size) return std::nullopt;
  }
  return next;
}

// The session to continue, if any, read before the map is opened for writing: a resumed session
// is opened with its own stored settings, and everything about the run is checked before anything
// is written. `known` is false when the map cannot be read this way (an older schema, upgraded by
// the read-write open; or a refused file, which Map::open then reports).
struct ResumeDecision {
  bool known = true;
  std::optional<ResumePoint> resume;
};

// The newest session over `source`, and whether the map still keeps its memory: the newest
// session of the map's main line (on a file, its last session) does, and so does a side session
// of a fleet map, begun while another writer held the map (schema/SCHEMA.md, "Fleet maps").
struct SessionOver {
  storage::SessionRecord record;
  bool resumable = false;
};

std::optional<SessionOver> newestSessionOver(const storage::MapStore& store,
                                             const ImageSource& source) {
  const std::vector<storage::SessionRecord> all = store.sessions();
  for (auto it = all.rbegin(); it != all.rend(); ++it) {
    if (!sameSource(it->source, source.canonicalPath())) continue;
    const storage::SessionMemory memory = store.sessionMemory(it->id);
    return SessionOver{*it,
                       memory == storage::SessionMemory::kMainLine ||
                           (memory == storage::SessionMemory::kOwn && store.sharedByWriters())};
  }
  return std::nullopt;
}

// An unfinished session over the source that can no longer resume: mapping the source again
// from frame 0 without a word would hide that its rest was never mapped.
Error unfinishedSession(const std::string& map_path, const storage::MapStore& store,
                        const storage::SessionRecord& session, std::int64_t next,
                        const ImageSource& source) {
  const auto size = source.size();
  const auto last = store.lastSession();
  return Error(
      ErrorCode::kInvalidArgument,
      fmt::format("session {} of {} over {} is unfinished ({} of {} frames mapped) and can no "
                  "longer resume: session {} began after it, and only a map's newest session "
                  "resumes (on a server, also a side session); give --new-session to map {} "
                  "again from frame 0 in a new session",
                  session.id, map_path, source.canonicalPath(), next,
                  size ? std::to_string(*size) : std::string("?"), last ? last->id : 0,
                  source.canonicalPath()));
}

ResumeDecision sessionToResume(const std::string& map_path, const ImageSource& source,
                               bool new_session) {
  if (new_session) return {};
  if (mapFileIsNew(map_path)) return {};
  try {
    const auto store_owner = storage::openMapStore(map_path, storage::OpenMode::kReadOnly);
    storage::MapStore& store = *store_owner;
    const auto newest = newestSessionOver(store, source);
    if (!newest) return {};
    const storage::SessionRecord& last = newest->record;
    auto next = resumeIndex(last, store.lastFrameIndex(last.id), source);
    if (!next) return {};
    if (!newest->resumable) throw unfinishedSession(map_path, store, last, *next, source);
    if (last.source_digest && !last.source_digest->empty() &&
        *last.source_digest != source.digest())
      throw Error(ErrorCode::kInvalidArgument,
                  fmt::format("cannot resume session {} of {}: {} changed since the session "
                              "began (its images differ: {} then, {} now), so frame {} would be "
                              "another image; use --new-session to map it as a new session",
                              last.id, map_path, source.canonicalPath(), *last.source_digest,
                              source.digest(), *next));
    return {true, ResumePoint{last.id, *next, store.settings(last.id)}};
  } catch (const storage::StorageError&) {
    return {false, std::nullopt};
  }
}

// The same decision on the open map, for maps the read-only look could not read.
std::optional<ResumePoint> sessionToResume(const Map& map, const ImageSource& source) {
  auto last = map.lastSession();
  if (!last) return std::nullopt;
  storage::SessionRecord record;
  record.source = last->source;
  record.clean_close = last->clean_close;
  auto next = resumeIndex(record, last->last_source_index, source);
  if (!next) return std::nullopt;
  return ResumePoint{last->id, *next, {}};
}

// "frame 1:52 closes a loop on frames 1:10 1:11 (location 12, score 0.874, 23 inliers, pose
// relative to 1:10)": every frame as SESSION:INDEX[@STAMP] (frame_names.h).
std::string closureLine(const FrameResult& r) {
  const auto& frames = r.hypothesis.frames;
  return fmt::format(
      "placedb: frame {} closes a loop on frame{} {} (location {}, score {:.3f}, {} inliers{})\n",
      frameName(r.session_id, r.source_index, r.stamp_ns), frames.size() == 1 ? "" : "s",
      frameNames(frames), r.hypothesis.location_id, r.hypothesis.score, r.hypothesis.inliers,
      r.hypothesis.pose && !frames.empty() ? ", pose relative to " + frameName(frames.front())
                                           : std::string());
}

// What the summary counts, frame by frame, so that a frame the map lost and this run maps again
// (a server's last commits, gone with it in a restart) is counted once.
class RunTally {
 public:
  explicit RunTally(MappingSummary& summary) : summary_(summary) {}
  void add(std::int64_t index, const FrameResult& r, bool unreadable) {
    std::uint8_t flags = 0;
    if (unreadable) flags |= kUnreadable;
    if (r.outcome == FrameOutcome::kBad) flags |= kBad;
    if (r.outcome == FrameOutcome::kNewLocation) flags |= kNewLocation;
    if (r.hypothesis.accepted) flags |= kClosure;
    frames_.push_back({index, flags});
    count(flags, 1);
  }
  // The map holds no frame from `index` on (a source's indices grow along the run).
  void forgetFrom(std::int64_t index) {
    while (!frames_.empty() && frames_.back().first >= index) {
      count(frames_.back().second, -1);
      frames_.pop_back();
    }
  }

 private:
  static constexpr std::uint8_t kUnreadable = 1, kBad = 2, kNewLocation = 4, kClosure = 8;
  void count(std::uint8_t flags, int sign) {
    summary_.processed += sign;
    summary_.unreadable += (flags & kUnreadable) ? sign : 0;
    summary_.bad += (flags & kBad) ? sign : 0;
    summary_.locations_created += (flags & kNewLocation) ? sign : 0;
    summary_.loop_closures += (flags & kClosure) ? sign : 0;
  }
  MappingSummary& summary_;
  std::vector<std::pair<std::int64_t, std::uint8_t>> frames_;  // index, flags
};

// The frame log of a session that goes on from `first_index` (a resume, or a reopen after a lost
// server): rows of frames the map does not hold are cut off (they are mapped again), and rows of
// frames the map holds but the log lacks (the run stopped between a frame's commit and its row)
// are written back from the map. Returns the frames written back.
std::vector<FrameResult> continueLog(const MappingRequest& request, std::int64_t session,
                                     std::int64_t first_index,
                                     std::unique_ptr<FrameLogWriter>& log) {
  log.reset();
  if (request.log_path.empty()) return {};
  const FrameLogWriter::CutBack cut =
      FrameLogWriter::cutBack(request.log_path, session, first_index);
  if (!cut.dropped.empty())
    printWarning(
        fmt::format("log {}: dropped the rows of frames {}-{}, which the map lost "
                    "(they are mapped again)",
                    request.log_path, cut.dropped.front(), cut.dropped.back()));
  log = std::make_unique<FrameLogWriter>(request.log_path);
  // Standard output cannot be read back: what its reader got is unknown.
  if (request.log_path == kStandardOutput.string()) return {};
  std::vector<FrameResult> missing =
      framesFromMap(request.map_path, session, cut.last_kept, first_index);
  for (const FrameResult& r : missing) log->writeFromMap(r);
  if (!missing.empty())
    printWarning(fmt::format(
        "log {}: wrote back from the map the rows of frame{} {}{}, which the map holds and the "
        "log lacked (the run stopped between a frame's commit and its row)",
        request.log_path, missing.size() == 1 ? "" : "s", missing.front().source_index,
        missing.size() == 1 ? "" : fmt::format("-{}", missing.back().source_index)));
  return missing;
}

// After the connection to a map's server was lost mid-run (a restart, the network): waits up to
// --server-wait for the server, reopens the map and resumes the session, exactly as a new run
// would. Throws kServerLost when the time runs out (or Ctrl-C comes first).
std::pair<std::unique_ptr<Map>, SessionInfo> reopenAfterLoss(const MappingRequest& request,
                                                             const Options& options,
                                                             std::int64_t session_id,
                                                             const Error& cause) {
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                           std::chrono::duration<double>(request.server_wait_s));
  std::string problem = cause.what();
  bool busy = false;
  while (true) {
    try {
      auto map = Map::open(request.map_path, options, Map::Mode::kMapping);
      SessionInfo info = map->resumeSession(session_id);
      return {std::move(map), std::move(info)};
    } catch (const Error& e) {
      // The server is still away, or still holds this writer's old connection (and with it the
      // session) until it notices that the connection is gone.
      if (e.code() != ErrorCode::kServerUnreachable && e.code() != ErrorCode::kMapBusy) throw;
      problem = e.what();
      busy = e.code() == ErrorCode::kMapBusy;
    }
    const auto left = deadline - Clock::now();
    if (left <= Clock::duration::zero() || interruptRequested()) break;
    std::this_thread::sleep_for(std::min<Clock::duration>(left, std::chrono::milliseconds(500)));
  }
  if (busy) throw Error(ErrorCode::kMapBusy, problem);
  throw Error(
      ErrorCode::kServerLost,
      fmt::format("{}: lost its server and could not reach it again within {} s "
                  "(--server-wait): {}; every committed frame is kept, run `placedb "
                  "map` again to resume",
                  storage::mapDisplayName(request.map_path), request.server_wait_s, problem));
}

// A new session. On a map on a server whose main line another writer holds and where no place
// is stored yet (robots started at the same instant on a new map), a side session cannot begin
// (map_fleet.cpp): it waits for that first place up to --server-wait, reopening the map each
// time so that it starts from what the map holds then.
SessionInfo beginNewSession(std::unique_ptr<Map>& map, const MappingRequest& request,
                            const Options& options, const ImageSource& source) {
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                           std::chrono::duration<double>(request.server_wait_s));
  bool noted = false;
  while (true) {
    try {
      return map->beginSession(source.canonicalPath(), source.digest());
    } catch (const Error& e) {
      if (e.code() != ErrorCode::kMapBusy || !storage::isServerMap(request.map_path)) throw;
      if (Clock::now() >= deadline || interruptRequested()) {
        if (!noted) throw;
        throw Error(ErrorCode::kMapBusy, fmt::format("{} (waited {} s: --server-wait)", e.what(),
                                                     request.server_wait_s));
      }
      if (!noted)
        printNote(
            fmt::format("{}: another writer holds the map and has not stored its first "
                        "place yet; waiting up to {} s for it (--server-wait)",
                        storage::mapDisplayName(request.map_path), request.server_wait_s));
      noted = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    map.reset();
    map = Map::open(request.map_path, options, Map::Mode::kMapping);
  }
}

// The server of the map went away while the run opened the map, after it had answered.
struct OpeningLost {
  std::string problem;
};

// One attempt at the whole run; `reached` when an earlier attempt reached the server.
MappingSummary runOnce(const MappingRequest& request, std::chrono::steady_clock::time_point started,
                       bool reached) {
  // Everything that can be refused is checked before the map file is touched.
  std::shared_ptr<ImageSource> source = request.opened_source;
  if (!source) source = ImageSource::open(request.source, request.source_options);
  Options options = resolveOptions(request.settings);
  const ResumeDecision decision = sessionToResume(request.map_path, *source, request.new_session);
  std::optional<ResumePoint> resume = decision.resume;
  if (resume) {
    // The session continues with the settings it started with, so its results stay exact.
    options = Options::fromStoredSettings(resume->settings);
    if (!request.settings.empty())
      printWarning(
          fmt::format("resuming session {}: it keeps the settings it started with; "
                      "--preset/--config/--set are ignored (use --new-session to change "
                      "them)",
                      resume->session_id));
  }
  auto checkLog = [&] {
    if (!request.log_path.empty())
      FrameLogWriter::checkAppendable(request.log_path,
                                      resume ? std::optional(resume->session_id) : std::nullopt);
  };
  if (decision.known) checkLog();
  for (const auto& skipped : source->skippedFiles())
    printWarning(fmt::format("skipping {}: not an image file", skipped));
  std::unique_ptr<FrameLogWriter> log;

  std::unique_ptr<Map> map;
  MappingSummary summary;
  try {
    map = Map::open(request.map_path, options, Map::Mode::kMapping);
    if (!decision.known && !request.new_session) {
      resume = sessionToResume(*map, *source);
      checkLog();
    }
    if (resume) {
      summary.first_index = resume->first_index;
      summary.session_id = map->resumeSession(resume->session_id).id;
      summary.resumed = true;
      source->seek(summary.first_index);
    } else {
      summary.session_id = beginNewSession(map, request, options, *source).id;
    }
  } catch (const Error& e) {
    // The look above reached the server (or an earlier attempt did), so it went away since: a
    // restart, the network. Nothing of this run was logged yet: runMapping starts it again.
    if (e.code() == ErrorCode::kServerUnreachable && storage::isServerMap(request.map_path) &&
        (decision.known || reached))
      throw OpeningLost{e.what()};
    throw;
  }
  if (resume)
    continueLog(request, summary.session_id, summary.first_index, log);
  else if (!request.log_path.empty())
    log = std::make_unique<FrameLogWriter>(request.log_path);
  if (!request.quiet)
    std::fputs(
        fmt::format("placedb: {} session {} of {} over {} {} from frame {}\n",
                    summary.resumed ? "resuming" : "starting", summary.session_id, request.map_path,
                    source->kind(), source->canonicalPath(), summary.first_index)
            .c_str(),
        stderr);

  summary.next_index = summary.first_index;
  std::optional<std::int64_t> remaining;
  if (auto size = source->size())
    remaining = std::max<std::int64_t>(0, *size - summary.first_index);
  if (request.stop_after)
    remaining = remaining ? std::min(*remaining, *request.stop_after) : *request.stop_after;
  std::unique_ptr<ProgressReporter> progress;
  if (!request.quiet)
    progress = std::make_unique<ProgressReporter>(remaining, ProgressReporter::stderrIsTerminal());

  RunTally tally(summary);
  SourceFrame frame;
  while (true) {
    if (interruptRequested()) {
      summary.interrupted = true;
      break;
    }
    if (request.stop_after && summary.processed >= *request.stop_after) {
      summary.stopped_early = true;
      break;
    }
    if (!source->read(frame)) {
      // A live source's wait for its next frame ends on Ctrl-C too: that is a stop, not its end.
      summary.interrupted = interruptRequested();
      summary.stalled = summary.interrupted ? std::string() : source->endProblem();
      summary.reached_end = !summary.interrupted && summary.stalled.empty();
      break;
    }
    FrameResult result;
    try {
      if (frame.image.empty()) {
        if (progress) progress->clearLine();
        printWarning(fmt::format("frame {} ({}): {}; recorded as a bad frame", frame.index,
                                 frame.path, frame.problem));
        result = map->recordUnreadable(frame.index, frame.path, frame.stamp_ns);
      } else {
        result = map->process(frame.image, frame.index, frame.path, frame.stamp_ns);
      }
    } catch (const Error& e) {
      if (e.code() != ErrorCode::kServerUnreachable || !storage::isServerMap(request.map_path))
        throw;
      if (progress) progress->clearLine();
      printWarning(fmt::format("lost the server at frame {}: {}; waiting up to {} s for it",
                               frame.index, e.what(), request.server_wait_s));
      log.reset();
      map.reset();  // closing fails quietly: the session stays open for the resume
      auto reopened = reopenAfterLoss(request, options, summary.session_id, e);
      map = std::move(reopened.first);
      const auto& last = reopened.second.last_source_index;
      const std::int64_t next = last ? *last + 1 : 0;
      // Frames the map lost with the server's last commits are mapped again (and counted once);
      // one the server committed as the connection went is in the map, its row written back.
      tally.forgetFrom(next);
      summary.next_index = next;
      if (source->kind() != "live") source->seek(next);
      for (const FrameResult& r : continueLog(request, summary.session_id, next, log))
        if (r.source_index >= summary.first_index) tally.add(r.source_index, r, false);
      printNote(fmt::format("the server is back: session {} goes on from frame {}",
                            summary.session_id, next));
      continue;
    }
    tally.add(frame.index, result, frame.image.empty());
    summary.next_index = frame.index + 1;
    if (result.hypothesis.accepted && progress) {
      progress->clearLine();
      std::fputs(closureLine(result).c_str(), stderr);
    }
    if (log) log->write(result);
    if (request.on_frame) request.on_frame(frame, result);
    if (progress)
      progress->update({frame.index, summary.locations_created,
                        static_cast<std::int64_t>(result.wm_size), summary.loop_closures,
                        dropsFrames(*source) ? std::optional(source->dropped()) : std::nullopt,
                        source->size()});
  }
  summary.dropped = source->dropped();
  try {
    map->close();
  } catch (const Error& e) {
    // Every frame is committed; only the session's clean close is left, once the server is back.
    if (e.code() != ErrorCode::kServerUnreachable || !storage::isServerMap(request.map_path)) throw;
    map.reset();
    reopenAfterLoss(request, options, summary.session_id, e).first->close();
  }
  if (progress) progress->finish();
  // What the next run over the source will do (the resume rule above, on a clean close): say
  // "run again to resume" only when it will.
  summary.live = source->kind() == "live";
  summary.source_size = source->size();
  summary.reached_end =
      summary.reached_end || (summary.source_size && summary.next_index >= *summary.source_size);
  summary.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return summary;
}

}  // namespace

std::string endOfRunText(const MappingSummary& s) {
  const std::string signal = fmt::format("stopped by {}", interruptSignalName());
  if (!s.stalled.empty()) return "stalled: the stream sent nothing";
  if (s.live) return s.interrupted ? signal + "; the session is closed" : "end of source";
  if (s.reached_end) return "end of source";
  const std::string why = s.interrupted ? signal : "stopped by --stop-after";
  if (!s.source_size)
    return fmt::format(
        "{}; the source's length is unknown, so the next `placedb map` over it starts a new "
        "session",
        why);
  return fmt::format(
      "{}; run the same command again to resume at frame {}, before another session begins on "
      "the map",
      why, s.next_index);
}

MappingSummary runMapping(const MappingRequest& request) {
  using Clock = std::chrono::steady_clock;
  const auto started = Clock::now();
  // From here on Ctrl-C only raises a flag: the frame loop acts on it.
  installInterruptHandlers();
  std::optional<Clock::time_point> deadline;
  while (true) {
    try {
      return runOnce(request, started, deadline.has_value());
    } catch (const OpeningLost& lost) {
      if (!deadline) {
        deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                      std::chrono::duration<double>(request.server_wait_s));
        printWarning(
            fmt::format("lost the server while opening the map: {}; waiting up to {} "
                        "s for it",
                        lost.problem, request.server_wait_s));
      }
      if (Clock::now() >= *deadline || interruptRequested())
        throw Error(ErrorCode::kServerLost,
                    fmt::format("{}: lost its server and could not reach it again within {} s "
                                "(--server-wait): {}; every committed frame is kept, run "
                                "`placedb map` again to resume",
                                storage::mapDisplayName(request.map_path), request.server_wait_s,
                                lost.problem));
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
    }
  }
}

}  // namespace placedb::cli
