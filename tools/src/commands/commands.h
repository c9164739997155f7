#pragma once
// Each subcommand registers itself on the top-level CLI11 app and returns what runs it once
// the command line is parsed. Runners return the exit status and throw placedb::Error (or any
// std::exception) on failure; main() turns those into one error line and the documented code.
#include <CLI/CLI.hpp>

#include <functional>

#include "settings_input.h"

namespace placedb::cli {

struct Command {
  CLI::App* app = nullptr;
  std::function<int()> run;
};

Command addMapCommand(CLI::App& parent);
Command addQueryCommand(CLI::App& parent);
Command addInfoCommand(CLI::App& parent);
Command addVocabCommand(CLI::App& parent);
Command addEvalCommand(CLI::App& parent);
Command addDemoCommand(CLI::App& parent);
Command addSettingsCommand(CLI::App& parent);
Command addExportCommand(CLI::App& parent);
Command addReportCommand(CLI::App& parent);
Command addCheckCommand(CLI::App& parent);
Command addCopyCommand(CLI::App& parent);

// --set, --config and --preset, shared by `map` and `demo`.
void addSettingsOptions(CLI::App& app, SettingsInput& settings);

}  // namespace placedb::cli
