#include <fmt/format.h>

#include <cstdio>
#include <memory>

#include "commands/commands.h"
#include "commands/mapping_run.h"
#include "exit_codes.h"
#include "frame_log.h"
#include "interrupt.h"
#include "map_argument.h"
#include "settings_input.h"
#include "sources/live_source.h"

namespace placedb::cli {
namespace {

// The log's columns as the code writes them, wrapped for --help.
std::string logColumnList() {
  std::string text, line;
  for (const auto& name : FrameLogWriter::columns()) {
    if (!line.empty() && line.size() + name.size() + 2 > 88) {
      text += line + "\n";
      line.clear();
    }
    line += (line.empty() ? "  " : " ") + name;
  }
  return text + line;
}

}  // namespace

// The settings options are shared by `map` and `demo`.
void addSettingsOptions(CLI::App& app, SettingsInput& settings) {
  app.add_option("--set", settings.assignments,
                 "engine setting KEY=VALUE, repeatable; wins over --config and --preset "
                 "(`placedb settings` lists them)")
      ->type_name("KEY=VALUE")
      ->allow_extra_args(false);
  app.add_option("--config", settings.config_file,
                 "settings file: `key = value` lines ('#' comments) or one JSON object");
  app.add_option("--preset", settings.preset,
                 "start from a preset: `paper` (paper 000, table 4) or `default`");
  app.add_option("--calibration", settings.calibration_file,
                 "camera intrinsics (settings fx fy cx cy): a line `fx fy cx cy`, an OpenCV "
                 "YAML/XML/JSON file with camera_matrix, or ROS camera_calibration's YAML; "
                 "accepted loop closures then store their relative pose");
}

Command addMapCommand(CLI::App& parent) {
  auto request = std::make_shared<MappingRequest>();
  auto stop_after = std::make_shared<std::int64_t>(0);
  CLI::App* app = parent.add_subcommand("map", "Map an image sequence (creates or continues MAP)");
  app->footer(
      "Process every frame of SOURCE into MAP, detecting loop closures.\n\n"
      "SOURCE is an image folder (natural order: 2.jpg before 10.jpg; non-image files are\n"
      "skipped), a list file (one image path a line, relative to the list file; blank lines\n"
      "and '#' comments ignored), a video file (.mp4, .avi, .mkv, ...), or a ROS bag: a ROS 1\n"
      "bag (.bag) or a ROS 2 bag (a folder with metadata.yaml and .db3 files, or one .db3\n"
      "file). A bag's sensor_msgs/Image or CompressedImage topic is read (--topic names it;\n"
      "the only image topic is the default) in mono8, mono16, bgr8, rgb8, bgra8, rgba8 or\n"
      "compressed JPEG/PNG, and each message's header.stamp is kept with its frame\n"
      "(frames.stamp_ns, the log's stamp_ns column). A bag resumes like a list file.\n"
      "A camera (camera:N or /dev/videoN) or a stream (rtsp://, http://, https://) is read\n"
      "live: each frame is the newest one, frames that arrive while the engine is busy are\n"
      "dropped and counted (progress and the summary show them), --fps caps the rate, Ctrl-C\n"
      "closes the session cleanly; a live source always starts a new session.\n\n"
      "MAP is a file, created when missing, or a map on a PostgreSQL server named by a libpq\n"
      "URI (postgresql://USER@HOST/DB, postgresql:///DB?host=SOCKET_DIR): the database must\n"
      "exist; its placedb tables are created when missing (scripts/pg-server.sh starts a\n"
      "scratch server). A password in the URI is never shown; PGPASSFILE, ~/.pgpass and\n"
      "sslmode= work as in psql. If its last session ran over the same SOURCE and did not\n"
      "reach its end (a crash, Ctrl-C or --stop-after), that session resumes with the first\n"
      "frame not yet processed; otherwise a new session starts. An unfinished session over\n"
      "SOURCE that another session came after can no longer resume: map says which (exit 2),\n"
      "and --new-session maps SOURCE again from frame 0. Frame numbers always count from\n"
      "the start of SOURCE. Unreadable images are recorded as bad frames with a warning.\n"
      "Several `map` runs may write one map on a server at once, each in its own session (a\n"
      "fleet map: a robot's session resumes as long as no other run writes it, exit 5\n"
      "otherwise; robots started at once on a new map wait for the first one's first place);\n"
      "a lost server is waited for (--server-wait), then exit 13.\n"
      "A session whose SOURCE lists other images than when it began is not resumed (exit 2;\n"
      "--new-session maps it anew).\n\n"
      "Settings: defaults < --preset < --config < --calibration < --set. A resumed session\n"
      "keeps its settings (camera intrinsics included). By default memory is unbounded\n"
      "(wm_max=0, t_time_ms=0: every location stays in working memory); --set wm_max=300\n"
      "keeps at most 300 there and the rest in long-term memory, on disk only.\n\n"
      "The --log CSV has one row per frame processed by this invocation; an existing log is\n"
      "appended to only by a resume of the session that wrote it (another run is exit 2),\n"
      "after the rows of frames the map lost (and maps again) are cut off and the rows of\n"
      "frames the map holds but the log lacks (a run stopped between the two) written back.\n"
      "Its columns:\n" +
      logColumnList() +
      "\nWhat each holds, and how closures onto other sessions' frames show: docs/log.md.\n"
      "Frames are named SESSION:INDEX, with @SECONDS.NANOSECONDS when the source stamps them.\n\n"
      "Examples:\n"
      "  placedb map run.placedb /data/lip6_outdoor/frames.txt --log run.csv\n"
      "  placedb map run.placedb images/ --set t_loop=0.2 --set wm_max=300\n"
      "  placedb map run.placedb walk.mp4 --preset paper --stop-after 500   # later: same again\n"
      "  placedb map run.placedb run.bag --topic /camera/image_raw/compressed\n"
      "  placedb map run.placedb camera:0 --fps 5          # Ctrl-C to stop\n"
      "  placedb map 'postgresql:///placedb?host=/tmp/pg' frames.txt   # a map on a server");
  app->add_option("MAP", request->map_path, "map: a file (SQLite) or a postgresql:// URI")
      ->required()
      ->transform(mapArgument());
  app->add_option("SOURCE", request->source, "image folder, list file, video or ROS bag")
      ->required();
  app->add_option("--topic", request->source_options.topic,
                  "a bag's image topic (sensor_msgs/Image or CompressedImage); default: the "
                  "bag's only image topic");
  app->add_option("--log", request->log_path,
                  "write (or append) the per-frame CSV log; - writes it to standard output");
  addSettingsOptions(*app, request->settings);
  app->add_option("--stop-after", *stop_after,
                  "process at most N frames, then close; the next `map` resumes")
      ->check(CLI::Validator(
          [](std::string& value) {
            try {
              if (std::stoll(value) >= 1) return std::string();
            } catch (const std::exception&) {
            }
            return "must be a whole number >= 1, got " + value;
          },
          "N >= 1"));
  app->add_option("--fps", request->source_options.max_fps,
                  "a camera's or stream's rate cap, frames a second (default: as fast as the "
                  "engine goes; frames arriving while it is busy are dropped and counted)")
      ->check(CLI::PositiveNumber);
  app->add_flag("--new-session", request->new_session,
                "start a new session even if the last one over SOURCE is unfinished");
  app->add_option("--server-wait", request->server_wait_s,
                  "a map on a server: when the connection is lost during the run, wait up to "
                  "this many seconds for the server, then go on where the map stands (default "
                  "60; 0: at once); after that, exit 13. Also how long a robot started with "
                  "others on a new map waits for the first one's first place (then exit 5)")
      ->type_name("SECONDS")
      ->check(CLI::Range(0.0, 86400.0));
  app->add_flag("--quiet,-q", request->quiet,
                "no progress, start line or loop-closure lines; the one-line summary, warnings "
                "and errors stay");
  return {app, [request, stop_after, app]() {
            if (app->count("--stop-after")) request->stop_after = *stop_after;
            const bool live = isLiveSource(request->source);
            MappingSummary s = runMapping(*request);
            if (!s.stalled.empty())
              printWarning(fmt::format("{}: the session is closed, every frame kept (exit {})",
                                       s.stalled, kExitSourceStalled));
            // Kept under --quiet: one line saying what the run did and what comes next.
            std::fputs(fmt::format("placedb: session {}: {} frames ({} bad, {} of them "
                                   "unreadable{}) in {:.1f} s, {} new locations, accepted loop "
                                   "closures {} ({})\n",
                                   s.session_id, s.processed, s.bad, s.unreadable,
                                   live ? fmt::format("; {} dropped while busy", s.dropped) : "",
                                   s.seconds, s.locations_created, s.loop_closures, endOfRunText(s))
                           .c_str(),
                       stderr);
            return s.stalled.empty() ? kExitOk : kExitSourceStalled;
          }};
}

Command addSettingsCommand(CLI::App& parent) {
  CLI::App* app = parent.add_subcommand("settings", "List every engine setting with its default");
  app->footer(
      "List the engine settings accepted by --set KEY=VALUE and --config, with default and\n"
      "valid values, and the RTAB-Map parameter names accepted in their place.\n\n"
      "Examples:\n  placedb settings\n  placedb settings --json | jq '.[].key'");
  auto json = std::make_shared<bool>(false);
  app->add_flag("--json", *json,
                "print a JSON array of {key, default, valid, description, aliases}");
  return {app, [json]() {
            std::fputs((*json ? settingsJson() : settingsHelp()).c_str(), stdout);
            return 0;
          }};
}

}  // namespace placedb::cli
