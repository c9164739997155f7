#pragma once
// Engine settings from the command line: `--preset paper`, `--config FILE`, `--set key=value`.
// Precedence: defaults (or the preset) < config file < --calibration < --set. Options::fromSettings
// refuses unknown keys and bad values with the list of valid ones.
//
// Config file: either lines `key = value` (blank lines and '#' comments ignored; a '#' after a
// value starts a comment too), or one JSON object {"key": value, ...} when the first
// non-blank character is '{' (numbers and booleans are taken as their text).
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "placedb/options.h"

namespace placedb::cli {

using Settings = std::map<std::string, std::string>;

struct SettingsInput {
  std::string preset;                    // "" or "paper"
  std::string config_file;               // "" when none
  std::vector<std::string> assignments;  // "key=value", later ones win
  std::string calibration_file;          // "" when none; fx fy cx cy (calibration_file.h)
  bool empty() const {
    return preset.empty() && config_file.empty() && assignments.empty() && calibration_file.empty();
  }
};

// Throws placedb::Error(kInvalidArgument) for an assignment without '=' or an empty key.
Settings parseAssignments(const std::vector<std::string>& assignments);
// Throws placedb::Error(kIo) when unreadable, kInvalidArgument when malformed.
Settings readConfigFile(const std::filesystem::path& path);
// The settings of a config file's content; `name` (the file) is named in every error.
// Throws placedb::Error(kInvalidArgument) when malformed.
Settings parseConfig(const std::string& content, const std::string& name);
Options presetOptions(const std::string& preset);
Options resolveOptions(const SettingsInput& input);
// The catalogue as a help text: key, default, valid values, description; then the aliases.
std::string settingsHelp();
// The catalogue as a JSON array of {key, default, valid, description, aliases}.
std::string settingsJson();

}  // namespace placedb::cli
