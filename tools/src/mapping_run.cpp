#include "mapping_run.h"
#include "map_argument.h"

#include <fmt/format.h>

#include <chrono>
#include <filesystem>
#include <map>
#include <memory>

#include "exit_codes.h"
#include "frame_log.h"
#include "image_source.h"
#include "interrupt.h"
#include "placedb/map.h"
#include "placedb/storage/map_store.h"
#include "progress.h"

namespace placedb::cli {
namespace {

bool sameSource(const std::string& stored, const std::string& canonical) {
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
  if (last.clean_close) {
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

ResumeDecision sessionToResume(const std::string& map_path, const ImageSource& source,
                               bool new_session) {
  if (new_session) return {};
  if (mapFileIsNew(map_path)) return {};
  try {
    const auto store_owner = storage::openMapStore(map_path, storage::OpenMode::kReadOnly);
    storage::MapStore& store = *store_owner;
    auto last = store.lastSession();
    if (!last) return {};
    auto next = resumeIndex(*last, store.lastFrameIndex(last->id), source);
    if (!next) return {};
    if (last->source_digest && !last->source_digest->empty() &&
        *last->source_digest != source.digest())
      throw Error(ErrorCode::kInvalidArgument,
                  fmt::format("cannot resume session {} of {}: {} changed since the session "
                              "began (its images differ: {} then, {} now), so frame {} would be "
                              "another image; use --new-session to map it as a new session",
                              last->id, map_path, source.canonicalPath(), *last->source_digest,
                              source.digest(), *next));
    return {true, ResumePoint{last->id, *next, store.settings(last->id)}};
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

// "frame 52 closes a loop on frames 10 11 (location 12, score 0.874, 23 inliers)"; frames of
// other sessions as SESSION:INDEX, as in the log.
std::string closureLine(const FrameResult& r) {
  std::string frames;
  for (const auto& ref : r.hypothesis.frames)
    frames +=
        (frames.empty() ? "" : " ") +
        (ref.session_id == r.session_id ? std::to_string(ref.source_index)
                                        : fmt::format("{}:{}", ref.session_id, ref.source_index));
  return fmt::format(
      "placedb: frame {} closes a loop on frame{} {} (location {}, score {:.3f}, "
      "{} inliers{})\n",
      r.source_index, r.hypothesis.frames.size() == 1 ? "" : "s", frames, r.hypothesis.location_id,
      r.hypothesis.score, r.hypothesis.inliers, r.hypothesis.pose ? ", pose" : "");
}

}  // namespace

MappingSummary runMapping(const MappingRequest& request) {
  auto started = std::chrono::steady_clock::now();
  // From here on Ctrl-C only raises a flag: the frame loop below acts on it.
  installInterruptHandlers();
  // Everything that can be refused is checked before the map file is touched.
  auto source = ImageSource::open(request.source, request.source_options);
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

  auto map = Map::open(request.map_path, options, Map::Mode::kMapping);
  MappingSummary summary;
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
    summary.session_id = map->beginSession(source->canonicalPath(), source->digest()).id;
  }
  if (!request.log_path.empty()) {
    if (resume) {
      const std::vector<std::int64_t> dropped =
          FrameLogWriter::cutBack(request.log_path, summary.session_id, summary.first_index);
      if (!dropped.empty())
        printWarning(
            fmt::format("log {}: dropped the rows of frames {}-{}, which the map lost "
                        "(they are mapped again)",
                        request.log_path, dropped.front(), dropped.back()));
    }
    log = std::make_unique<FrameLogWriter>(request.log_path);
  }
  if (!request.quiet)
    std::fputs(
        fmt::format("placedb: {} session {} of {} over {} {} from frame {}\n",
                    summary.resumed ? "resuming" : "starting", summary.session_id, request.map_path,
                    source->kind(), source->canonicalPath(), summary.first_index)
            .c_str(),
        stderr);

  std::optional<std::int64_t> remaining;
  if (auto size = source->size())
    remaining = std::max<std::int64_t>(0, *size - summary.first_index);
  if (request.stop_after)
    remaining = remaining ? std::min(*remaining, *request.stop_after) : *request.stop_after;
  std::unique_ptr<ProgressReporter> progress;
  if (!request.quiet)
    progress = std::make_unique<ProgressReporter>(remaining, ProgressReporter::stderrIsTerminal());

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
      summary.reached_end = true;
      break;
    }
    FrameResult result;
    if (frame.image.empty()) {
      if (progress) progress->clearLine();
      printWarning(fmt::format("frame {} ({}): {}; recorded as a bad frame", frame.index,
                               frame.path, frame.problem));
      result = map->recordUnreadable(frame.index, frame.path, frame.stamp_ns);
      ++summary.unreadable;
    } else {
      result = map->process(frame.image, frame.index, frame.path, frame.stamp_ns);
    }
    ++summary.processed;
    if (result.outcome == FrameOutcome::kNewLocation) ++summary.locations_created;
    if (result.outcome == FrameOutcome::kBad) ++summary.bad;
    if (result.hypothesis.accepted) {
      ++summary.loop_closures;
      if (progress) {
        progress->clearLine();
        std::fputs(closureLine(result).c_str(), stderr);
      }
    }
    if (log) log->write(result);
    if (progress)
      progress->update({frame.index, summary.locations_created,
                        static_cast<std::int64_t>(result.wm_size), summary.loop_closures,
                        source->kind() == "live" ? std::optional(source->dropped()) : std::nullopt,
                        source->size()});
  }
  summary.dropped = source->dropped();
  map->close();
  if (progress) progress->finish();
  summary.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return summary;
}

}  // namespace placedb::cli
