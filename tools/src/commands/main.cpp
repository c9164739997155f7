// placedb: the command line. Dispatches to one subcommand and turns every failure into one
// "placedb: error: ..." line and a documented exit status (see exit_codes.h).
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "commands/commands.h"
#include "exit_codes.h"
#include "features/cpu_support.h"
#include "map_argument.h"
#include "placedb/error.h"
#include "placedb/version.h"

namespace {

using placedb::cli::Command;

int run(std::vector<std::string>& arguments) {
  CLI::App app{fmt::format(
      "placedb {}: appearance-based loop-closure detection with a SQLite map.\n\n"
      "Typical use:\n"
      "  placedb map run.placedb images/ --log run.csv      map a folder, log every frame\n"
      "  placedb map run.placedb run.bag --topic /cam/image a ROS bag (or camera:0, rtsp://)\n"
      "  placedb eval run.csv gt_pairs.txt --plots plots/   score the run, draw its figures\n"
      "  placedb report run.placedb run.csv --out r/        one HTML page: figures, thumbnails\n"
      "                                                     of the closures (scores with a GT)\n"
      "  placedb query run.placedb photo.jpg                where was this photo taken?\n"
      "  placedb info run.placedb                           what the map holds\n"
      "  placedb check run.placedb                          is it sound? (pages, checksums)\n"
      "  placedb export run.placedb g.g2o                   graph for a pose-graph optimiser\n"
      "  placedb copy run.placedb postgresql://h/fleet      upload a map to a server (any way)\n"
      "  placedb demo --out demo-output                     all of it on a synthetic tour\n",
      PLACEDB_VERSION_STRING)};
  app.name("placedb");
  app.footer(placedb::cli::exitCodeTable());
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(PLACEDB_VERSION_STRING) +
                                        " (license " PLACEDB_LICENSE ", see LICENSE)");
  // The help to point at is that of the deepest subcommand named on the command line, also when
  // the error (a missing argument) is reported by the top-level app.
  app.failure_message([](const CLI::App* failed, const CLI::Error& e) {
    std::string command = "placedb";
    for (const CLI::App* a = failed; a;) {
      if (a->get_parent()) command += " " + a->get_name();
      const auto chosen = a->get_subcommands();
      a = chosen.empty() ? nullptr : chosen.front();
    }
    return fmt::format("placedb: error: {}\nRun `{} --help` for usage.\n", e.what(), command);
  });

  std::vector<Command> commands = {
      placedb::cli::addMapCommand(app),      placedb::cli::addQueryCommand(app),
      placedb::cli::addInfoCommand(app),     placedb::cli::addVocabCommand(app),
      placedb::cli::addEvalCommand(app),     placedb::cli::addDemoCommand(app),
      placedb::cli::addSettingsCommand(app), placedb::cli::addExportCommand(app),
      placedb::cli::addReportCommand(app),   placedb::cli::addCheckCommand(app),
      placedb::cli::addCopyCommand(app)};

  std::vector<char*> argv;
  for (std::string& argument : arguments) argv.push_back(argument.data());
  try {
    app.parse(static_cast<int>(argv.size()), argv.data());
  } catch (const CLI::ParseError& e) {
    int code = app.exit(e);  // prints help, version or the failure message
    return code == 0 ? placedb::cli::kExitOk : placedb::cli::kExitUsage;
  }
  for (const auto& command : commands)
    if (command.app->parsed()) return command.run();
  return placedb::cli::kExitUsage;
}

}  // namespace

int main(int argc, char** argv) {
  using placedb::cli::printError;
  // Before anything else runs: the parser reads copies, while the process's own arguments lose
  // any password a map's URI holds, which ps and /proc/PID/cmdline would show to every user.
  std::vector<std::string> arguments(argv, argv + argc);
  placedb::cli::hidePasswordsInArguments(argc, argv);
  // A write past a file-size limit (ulimit -f) then fails with EFBIG and is reported as a full
  // disk, instead of killing the process in the middle of a file.
  std::signal(SIGXFSZ, SIG_IGN);
  try {
    placedb::simdLevel();  // an invalid PLACEDB_SIMD is refused before any file is written
    return run(arguments);
  } catch (const placedb::Error& e) {
    printError(e.what());
    return placedb::cli::exitCodeFor(e.code());
  } catch (const cv::Exception& e) {
    printError(fmt::format("OpenCV: {}", e.what()));
    return placedb::cli::exitCodeFor(placedb::ErrorCode::kInternal);
  } catch (const std::bad_alloc&) {
    printError("out of memory");
    return placedb::cli::exitCodeFor(placedb::ErrorCode::kInternal);
  } catch (const std::exception& e) {
    printError(e.what());
    return placedb::cli::exitCodeFor(placedb::ErrorCode::kInternal);
  } catch (...) {
    printError("unknown failure");
    return placedb::cli::exitCodeFor(placedb::ErrorCode::kInternal);
  }
}
