// placedb check MAP: is this map sound, before a mission relies on it?
#include <fmt/format.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "commands/commands.h"
#include "commands/map_summary.h"
#include "exit_codes.h"
#include "map_argument.h"
#include "placedb/error.h"
#include "placedb/map.h"
#include "placedb/options.h"
#include "placedb/storage/map_check.h"
#include "placedb/storage/map_store.h"
#include "placedb/storage/migrations.h"

namespace placedb::cli {
namespace {

// The engine's own load checks (counters, weights, the posterior, the kd-forest's shape) run
// when a map opens; opening it for localisation, as `query` does, runs them all without a write.
std::string checkAsTheEngineLoads(const std::string& path) {
  try {
    const auto options = lastSessionOptions(path);
    if (!options) return "";  // nothing mapped yet: no engine state to load
    Map::open(path, *options, Map::Mode::kLocalisation);
  } catch (const Error& e) {
    if (e.code() != ErrorCode::kMapRefused) throw;
    return e.what();
  }
  return "";
}

nlohmann::json toJson(const std::string& path, const storage::CheckReport& report) {
  nlohmann::json findings = nlohmann::json::array();
  for (const auto& f : report.findings)
    findings.push_back({{"table", f.table}, {"row", f.row}, {"problem", f.problem}});
  return {{"map", path},
          {"ok", report.ok()},
          {"schema_version", report.schema_version},
          {"checksums", report.checksums},
          {"constraints_checked", report.constraints_checked},
          {"rows_checked", report.rows_checked},
          {"findings_total", report.findings_total},
          {"findings", findings}};
}

std::string describe(const std::string& path, const storage::CheckReport& report) {
  std::string text = fmt::format("map {} (schema {})\n", path, report.schema_version);
  if (report.schema_version < storage::currentSchemaVersion())
    text += fmt::format(
        "  schema {} is older than this binary's {}: `map` upgrades it when it first opens it; "
        "`query`, `info` and the engine's own checks wait until then\n",
        report.schema_version, storage::currentSchemaVersion());
  text += fmt::format("  pages, indexes and constraints: {}\n",
                      storage::isServerMap(path)
                          ? "the server's (constraints always enforced; pages: data checksums "
                            "or pg_amcheck)"
                      : report.constraints_checked
                          ? "checked (SQLite's integrity_check)"
                          : "checked, CHECK constraints not (the file could only be opened "
                            "read-only)");
  if (report.checksums) {
    std::string counts;
    for (const auto& [table, rows] : report.rows_checked)
      counts += fmt::format("{}{} {}", counts.empty() ? "" : ", ", rows, table);
    text += fmt::format("  checksums verified: {}\n", counts.empty() ? "none" : counts);
  } else {
    text += "  checksums: none yet (schema before 8; the first read-write open adds them)\n";
  }
  if (report.ok()) return text + "  sound: no damage found\n";
  for (const auto& f : report.findings)
    text += fmt::format("  damaged: {}{}{} {}\n", f.table, f.row.empty() ? "" : " row ", f.row,
                        f.problem);
  if (report.findings_total > static_cast<std::int64_t>(report.findings.size()))
    text += fmt::format("  ... and {} more\n", report.findings_total - report.findings.size());
  return text;
}

int runCheck(const std::string& path, bool json, bool quiet) {
  requireExistingMap(path);
  storage::CheckOptions options;
  const bool terminal = isatty(STDERR_FILENO) == 1;
  if (!quiet)
    options.progress = [terminal,
                        last_stage = std::string()](const storage::CheckProgress& p) mutable {
      if (!terminal && p.stage == last_stage) return;  // a log gets one line per stage
      last_stage = p.stage;
      const std::string line = p.total > 0
                                   ? fmt::format("check: {} {}/{}", p.stage, p.done, p.total)
                                   : fmt::format("check: {}", p.stage);
      std::fputs(terminal ? ("\r\033[K" + line).c_str() : (line + "\n").c_str(), stderr);
    };
  options.last_check = [&path] { return checkAsTheEngineLoads(path); };
  storage::CheckReport report = storage::checkMap(path, options);
  if (!quiet && terminal) std::fputs("\r\033[K", stderr);
  std::fputs((json ? toJson(path, report).dump(2) + "\n" : describe(path, report)).c_str(), stdout);
  if (report.ok()) return 0;
  const auto& first = report.findings.front();
  printError(fmt::format("map {} damaged: {} finding{} (first: {}{}{} {})", path,
                         report.findings_total, report.findings_total == 1 ? "" : "s", first.table,
                         first.row.empty() ? "" : " row ", first.row, first.problem));
  return exitCodeFor(ErrorCode::kMapRefused);
}

}  // namespace

Command addCheckCommand(CLI::App& parent) {
  auto path = std::make_shared<std::string>();
  auto json = std::make_shared<bool>(false);
  auto quiet = std::make_shared<bool>(false);
  CLI::App* app =
      parent.add_subcommand("check", "Verify every page, checksum and stored value of a map");
  app->footer(
      "Reads the whole map and reports damage before a mission relies on it:\n"
      "  - SQLite's integrity_check (pages, records, indexes, NOT NULL and CHECK constraints;\n"
      "    run on a connection that could write, the only kind on which SQLite checks CHECK)\n"
      "  - foreign keys\n"
      "  - the CRC-32C stored beside every word descriptor, place code, engine-state value and\n"
      "    kd-forest node (schema 8), and the recorded number of kd-forest nodes\n"
      "  - what each location's and session's rows must hold (schema 15): the rows a location\n"
      "    has, its references against their digest, its links, each session's settings;\n"
      "    every frame's coverage and hypothesis; the tables against the schema version\n"
      "  - values the engine refuses: non-finite descriptors, negative weights, probabilities\n"
      "    outside [0, 1], and the engine's own load checks (it opens the map as `query` does:\n"
      "    the counters against the rows, the tiers, the posterior)\n"
      "Nothing is written: the map and its -wal file are left as found, and a `placedb map`\n"
      "running on it is not disturbed (the check sees its last committed frame).\n"
      "Progress goes to stderr (-q to silence it). Exit 0 when sound, 4 when damage is found\n"
      "(each damaged row is listed: table and key), 3 when the file cannot be read.\n\n"
      "Examples:\n"
      "  placedb check run.placedb\n"
      "  placedb check run.placedb --json | jq '.findings'");
  app->add_option("MAP", *path, "map: a file or a postgresql:// URI")
      ->required()
      ->transform(mapArgument());
  app->add_flag("--json", *json, "print one JSON object: ok, rows_checked, findings");
  app->add_flag("-q,--quiet", *quiet, "no progress on stderr");
  return {app, [path, json, quiet]() { return runCheck(*path, *json, *quiet); }};
}

}  // namespace placedb::cli
