#include "mapping_run.h"

#include <fmt/format.h>

#include <chrono>
#include <filesystem>
#include <memory>

#include "exit_codes.h"
#include "frame_log.h"
#include "image_source.h"
#include "interrupt.h"
#include "placedb/map.h"
#include "progress.h"

namespace placedb::cli {
namespace {

bool sameSource(const std::string& stored, const std::string& canonical) {
  std::error_code ec;
  auto resolved = std::filesystem::weakly_canonical(stored, ec);
  return (ec ? std::filesystem::path(stored) : resolved).string() == canonical;
}

// The session to continue, if any (see the resume rule in mapping_run.h).
std::optional<SessionInfo> sessionToResume(const Map& map, const ImageSource& source,
                                           bool new_session) {
  if (new_session) return std::nullopt;
  auto last = map.lastSession();
  if (!last || !sameSource(last->source, source.canonicalPath())) return std::nullopt;
  if (!last->clean_close) return last;
  std::int64_t next = last->last_source_index ? *last->last_source_index + 1 : 0;
  // A source of unknown length cannot tell whether it was finished: treat it as finished.
  auto size = source.size();
  if (size && next < *size) return last;
  return std::nullopt;
}

}  // namespace

MappingSummary runMapping(const MappingRequest& request) {
  auto started = std::chrono::steady_clock::now();
  // From here on Ctrl-C only raises a flag: the frame loop below acts on it.
  installInterruptHandlers();
  // Everything that can be refused is checked before the map file is touched.
  auto source = ImageSource::open(request.source);
  Options options = resolveOptions(request.settings);
  for (const auto& skipped : source->skippedFiles())
    printWarning(fmt::format("skipping {}: not an image file", skipped));
  std::unique_ptr<FrameLogWriter> log;

  auto map = Map::open(request.map_path, options, Map::Mode::kMapping);
  MappingSummary summary;
  if (auto resume = sessionToResume(*map, *source, request.new_session)) {
    summary.first_index = resume->last_source_index ? *resume->last_source_index + 1 : 0;
    if (!request.settings.empty())
      printWarning(
          fmt::format("resuming session {}: it keeps the settings it started with; "
                      "--preset/--config/--set are ignored (use --new-session to change "
                      "them)",
                      resume->id));
    summary.session_id = map->resumeSession(resume->id).id;
    summary.resumed = true;
    source->seek(summary.first_index);
  } else {
    summary.session_id = map->beginSession(source->canonicalPath()).id;
  }
  if (!request.log_path.empty()) log = std::make_unique<FrameLogWriter>(request.log_path);
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
      result = map->recordUnreadable(frame.index, frame.path);
      ++summary.unreadable;
    } else {
      result = map->process(frame.image, frame.index, frame.path);
    }
    ++summary.processed;
    if (result.outcome == FrameOutcome::kNewLocation) ++summary.locations_created;
    if (result.hypothesis.accepted) ++summary.loop_closures;
    if (log) log->write(result);
    if (progress)
      progress->update({frame.index, summary.locations_created,
                        static_cast<std::int64_t>(result.wm_size), summary.loop_closures});
  }
  map->close();
  if (progress) progress->finish();
  summary.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return summary;
}

}  // namespace placedb::cli
