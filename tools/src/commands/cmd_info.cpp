#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <tuple>

#include "commands/commands.h"
#include "commands/map_summary.h"
#include "map_argument.h"
#include "placedb/error.h"
#include "placedb/options.h"
#include "placedb/storage/map_files.h"
#include "placedb/storage/map_store.h"

namespace placedb::cli {
namespace {

const char* linkName(storage::LinkType type) {
  switch (type) {
    case storage::LinkType::kNeighbour:
      return "neighbour";
    case storage::LinkType::kLoopClosure:
      return "loop_closure";
    case storage::LinkType::kMerge:
      return "merge";
  }
  return "?";
}

}  // namespace

std::optional<Options> lastSessionOptions(const std::string& path) {
  const auto store_owner = storage::openMapStore(path, storage::OpenMode::kReadOnly);
  storage::MapStore& store = *store_owner;
  const auto last = store.lastSession();
  if (!last) return std::nullopt;
  return Options::fromStoredSettings(store.settings(last->id));
}

nlohmann::json inspectMap(const std::string& path) {
  requireExistingMap(path);
  const auto store_owner = storage::openMapStore(path, storage::OpenMode::kReadOnly);
  storage::MapStore& store = *store_owner;
  nlohmann::json info;
  info["path"] = storage::mapDisplayName(path);  // a URI without its password
  // Committed frames may still sit in the write-ahead log (while a writer has the map open, or
  // after a crash): they count too. SQLite names the log after the file a link points to.
  if (storage::isServerMap(path)) {
    // A map on a server has no file; its size is the server's business (pg_database_size).
    info["file_bytes"] = nullptr;
    info["wal_bytes"] = nullptr;
  } else {
    std::error_code ec;
    const auto target = std::filesystem::canonical(path, ec);
    const auto wal = std::filesystem::file_size(storage::walFile(target.string()), ec);
    const std::uintmax_t wal_bytes = ec ? 0 : wal;
    info["file_bytes"] = std::filesystem::file_size(path) + wal_bytes;
    info["wal_bytes"] = wal_bytes;
  }
  info["schema_version"] = store.schemaVersion();
  info["frames"] = store.frameCount();
  info["bad_frames"] = store.frameCount(storage::FrameOutcome::kBad);
  info["words"] = store.wordCount();
  // Stored words include those of LTM locations; the kd-index holds STM, WM and imported ones.
  const auto last_frame = store.lastFrame();
  info["index_words"] =
      last_frame ? nlohmann::json(last_frame->stats.vocabulary_size) : nlohmann::json();
  // One definition of each count, in the words map's summary uses: accepted closures are
  // frames whose hypothesis was accepted, loop closures are links between two locations.
  info["loop_closures"] = store.linkCount(storage::LinkType::kLoopClosure);
  info["accepted_closures"] = store.acceptedClosureCount();
  info["posed_closures"] = store.acceptedClosureCount(/*posed=*/true);

  // Locations per tier, and which session made each one (for the links between sessions).
  std::map<std::int64_t, std::int64_t> session_of;
  nlohmann::json tiers;
  std::int64_t locations = 0;
  for (auto tier : {storage::Tier::kStm, storage::Tier::kWm, storage::Tier::kLtm}) {
    auto in_tier = store.locationsInTier(tier);
    tiers[storage::toString(tier)] = in_tier.size();
    locations += static_cast<std::int64_t>(in_tier.size());
    for (const auto& l : in_tier)
      if (auto record = store.location(l.id)) session_of[l.id] = record->session_id;
  }
  info["locations"] = locations;
  info["locations_per_tier"] = tiers;

  // Links whose two ends were created by different sessions, counted per session pair and type.
  std::map<std::tuple<std::int64_t, std::int64_t, std::string>, std::int64_t> cross;
  for (const auto& [id, session] : session_of)
    for (const auto& link : store.links(id)) {
      if (link.location_a != id) continue;  // each pair once
      auto other = session_of.find(link.location_b);
      if (other == session_of.end() || other->second == session) continue;
      auto pair = std::minmax(session, other->second);
      ++cross[{pair.first, pair.second, linkName(link.type)}];
    }
  nlohmann::json links = nlohmann::json::array();
  for (const auto& [key, count] : cross)
    links.push_back({{"session_a", std::get<0>(key)},
                     {"session_b", std::get<1>(key)},
                     {"type", std::get<2>(key)},
                     {"count", count}});
  info["links_between_sessions"] = links;

  nlohmann::json sessions = nlohmann::json::array();
  for (const auto& s : store.sessions()) {
    auto last = store.lastFrameIndex(s.id);
    // Where its memory is (schema/SCHEMA.md, fleet maps): whether it can be resumed.
    const storage::SessionMemory memory = store.sessionMemory(s.id);
    sessions.push_back({{"id", s.id},
                        {"memory", memory == storage::SessionMemory::kMainLine ? "main line"
                                   : memory == storage::SessionMemory::kOwn    ? "own"
                                                                               : "continued"},
                        {"source", s.source},
                        {"started_at", s.started_at},
                        {"ended_at", s.ended_at ? nlohmann::json(*s.ended_at) : nlohmann::json()},
                        {"clean_close", s.clean_close},
                        {"software_version", s.software_version},
                        {"frames", store.frameCount(s.id)},
                        {"last_source_index", last ? nlohmann::json(*last) : nlohmann::json()},
                        {"settings", store.settings(s.id)}});
  }
  info["sessions"] = sessions;

  nlohmann::json imports = nlohmann::json::array();
  for (const auto& v : store.vocabularyImports())
    imports.push_back({{"id", v.id},
                       {"file", v.file},
                       {"words", v.word_count},
                       {"mode", v.mode == storage::VocabularyMode::kFixed ? "fixed" : "seed"},
                       {"imported_at", v.imported_at}});
  info["vocabulary_imports"] = imports;
  return info;
}

namespace {

std::string describe(const nlohmann::json& info) {
  std::string text = fmt::format(
      "map {}: {}, schema version {}\n"
      "frames {} ({} bad), accepted loop closures {} ({} with a pose), loop-closure links {}\n"
      "words {} stored{}\n"
      "locations {} (STM {}, WM {}, LTM {})\n",
      info["path"].get<std::string>(),
      info["file_bytes"].is_null()
          ? std::string("on a PostgreSQL server")
          : fmt::format("{:.1f} MiB", info["file_bytes"].get<double>() / (1024.0 * 1024.0)),
      info["schema_version"].get<int>(), info["frames"].get<std::int64_t>(),
      info["bad_frames"].get<std::int64_t>(), info["accepted_closures"].get<std::int64_t>(),
      info["posed_closures"].get<std::int64_t>(), info["loop_closures"].get<std::int64_t>(),
      info["words"].get<std::int64_t>(),
      info["index_words"].is_null() ? std::string()
                                    : fmt::format(", {} in the kd-index after the last frame",
                                                  info["index_words"].get<std::int64_t>()),
      info["locations"].get<std::int64_t>(), info["locations_per_tier"]["stm"].get<std::int64_t>(),
      info["locations_per_tier"]["wm"].get<std::int64_t>(),
      info["locations_per_tier"]["ltm"].get<std::int64_t>());
  const auto defaults = Options().toSettings();
  for (const auto& s : info["sessions"]) {
    std::string state = s["clean_close"].get<bool>()
                            ? "closed cleanly"
                            : (s["ended_at"].is_null() ? "open or interrupted" : "ended");
    // A side session of a fleet map: its memory in rows of its own (a file shows none).
    if (s["memory"] == "own") state += ", its own memory (a side session)";
    text += fmt::format(
        "session {}: {} frames (last index {}), {}, started {}{}\n  source {}\n",
        s["id"].get<std::int64_t>(), s["frames"].get<std::int64_t>(),
        s["last_source_index"].is_null() ? std::string("-") : s["last_source_index"].dump(), state,
        s["started_at"].get<std::string>(),
        s["ended_at"].is_null() ? "" : ", ended " + s["ended_at"].get<std::string>(),
        s["source"].get<std::string>());
    std::string changed;
    for (const auto& [key, value] : s["settings"].items()) {
      auto d = defaults.find(key);
      if (d == defaults.end() || d->second != value.get<std::string>())
        changed +=
            fmt::format("{}{}={}", changed.empty() ? "" : " ", key, value.get<std::string>());
    }
    text += fmt::format("  settings: {}\n", changed.empty() ? "defaults" : changed);
  }
  for (const auto& l : info["links_between_sessions"])
    text += fmt::format("links between sessions {} and {}: {} {}\n",
                        l["session_a"].get<std::int64_t>(), l["session_b"].get<std::int64_t>(),
                        l["count"].get<std::int64_t>(), l["type"].get<std::string>());
  if (info["links_between_sessions"].empty() && info["sessions"].size() > 1)
    text += "no links between sessions\n";
  for (const auto& v : info["vocabulary_imports"])
    text += fmt::format("vocabulary import {}: {} words from {} ({})\n",
                        v["id"].get<std::int64_t>(), v["words"].get<std::int64_t>(),
                        v["file"].get<std::string>(), v["mode"].get<std::string>());
  return text;
}

}  // namespace

Command addInfoCommand(CLI::App& parent) {
  auto path = std::make_shared<std::string>();
  auto json = std::make_shared<bool>(false);
  CLI::App* app = parent.add_subcommand("info", "Describe what a map holds (read-only)");
  app->footer(
      "Print a map's sessions (source, frames, state, settings that differ from the defaults),\n"
      "its bad frames and loop closures, its locations per memory tier, its words (stored, and\n"
      "in the kd-index after the last frame), links between sessions, vocabulary imports and\n"
      "file size. The map is opened read-only; a running `placedb map` is not disturbed.\n\n"
      "Examples:\n"
      "  placedb info run.placedb\n"
      "  placedb info run.placedb --json | jq '.sessions[].frames'");
  app->add_option("MAP", *path, "map: a file or a postgresql:// URI")
      ->required()
      ->transform(mapArgument());
  app->add_flag("--json", *json, "print one JSON object (all settings included)");
  return {app, [path, json]() {
            nlohmann::json info = inspectMap(*path);
            std::fputs((*json ? info.dump(2) + "\n" : describe(info)).c_str(), stdout);
            return 0;
          }};
}

}  // namespace placedb::cli
