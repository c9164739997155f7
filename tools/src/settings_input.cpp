#include "settings_input.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <nlohmann/json.hpp>

#include "calibration_file.h"
#include "placedb/error.h"
#include "text_file.h"

namespace placedb::cli {
namespace {

Settings parseJsonConfig(const std::string& content, const std::string& name) {
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(content);
  } catch (const nlohmann::json::exception& e) {
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("config {}: bad JSON: {}", name, e.what()));
  }
  if (!doc.is_object())
    throw Error(ErrorCode::kInvalidArgument, fmt::format("config {}: not a JSON object", name));
  Settings settings;
  for (const auto& [key, value] : doc.items()) {
    if (trim(key).empty())
      throw Error(ErrorCode::kInvalidArgument, fmt::format("config {}: empty key", name));
    if (key.find('\0') != std::string::npos ||
        (value.is_string() && value.get<std::string>().find('\0') != std::string::npos))
      throw Error(ErrorCode::kInvalidArgument,
                  fmt::format("config {}: a key or value holds a NUL character (\\u0000)", name));
    if (value.is_string())
      settings[key] = value.get<std::string>();
    else if (value.is_number() || value.is_boolean())
      settings[key] = value.dump();
    else
      throw Error(
          ErrorCode::kInvalidArgument,
          fmt::format("config {}: value of {} must be a string, number or boolean", name, key));
  }
  return settings;
}

Settings parseLineConfig(const std::string& content, const std::string& name) {
  Settings settings;
  std::size_t start = 0;
  int line_number = 0;
  while (start < content.size()) {
    std::size_t end = content.find('\n', start);
    if (end == std::string::npos) end = content.size();
    std::string line = content.substr(start, end - start);
    start = end + 1;
    ++line_number;
    if (auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    line = trim(line);
    if (line.empty()) continue;
    auto eq = line.find('=');
    if (eq == std::string::npos || trim(line.substr(0, eq)).empty())
      throw Error(ErrorCode::kInvalidArgument,
                  fmt::format("config {} line {}: expected `key = value`, got `{}`", name,
                              line_number, line));
    settings[trim(line.substr(0, eq))] = trim(line.substr(eq + 1));
  }
  return settings;
}

}  // namespace

Settings parseAssignments(const std::vector<std::string>& assignments) {
  Settings settings;
  for (const auto& text : assignments) {
    auto eq = text.find('=');
    if (eq == std::string::npos || trim(text.substr(0, eq)).empty())
      throw Error(
          ErrorCode::kInvalidArgument,
          fmt::format("--set expects KEY=VALUE, got `{}` (see `placedb map --help`)", text));
    settings[trim(text.substr(0, eq))] = trim(text.substr(eq + 1));
  }
  return settings;
}

Settings parseConfig(const std::string& text, const std::string& name) {
  const std::string content = withoutByteOrderMark(text);
  std::string head = trim(content);
  // A NUL byte would end the error message that quotes its line, and no setting holds one.
  if (const auto nul = content.find('\0'); nul != std::string::npos)
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("config {} line {}: holds a NUL byte (a binary file?)", name,
                            1 + std::count(content.begin(), content.begin() + nul, '\n')));
  if (!head.empty() && head[0] == '{') return parseJsonConfig(content, name);
  return parseLineConfig(content, name);
}

Settings readConfigFile(const std::filesystem::path& path) {
  return parseConfig(readTextFile(path, "config file"), path.string());
}

Options presetOptions(const std::string& preset) {
  if (preset.empty() || preset == "default") return Options();
  if (preset == "paper") return Options::paperPreset();
  throw Error(ErrorCode::kInvalidArgument,
              fmt::format("unknown preset `{}` (valid: default|paper)", preset));
}

Options resolveOptions(const SettingsInput& input) {
  Options base = presetOptions(input.preset);
  Settings merged;
  if (!input.config_file.empty()) merged = readConfigFile(input.config_file);
  if (!input.calibration_file.empty())
    for (const auto& [key, value] : readCalibrationFile(input.calibration_file))
      merged[key] = value;
  for (const auto& [key, value] : parseAssignments(input.assignments)) merged[key] = value;
  return Options::fromSettings(merged, base);
}

std::string settingsHelp() {
  std::string text = "Settings (--set KEY=VALUE; default and valid values):\n";
  // Columns as wide as their longest entry, so a long key never pushes its row out of line.
  std::size_t key = 0, value = 0, valid = 0, alias = 0;
  for (const auto& info : Options::catalogue()) {
    key = std::max(key, info.key.size());
    value = std::max(value, info.default_value.size());
    valid = std::max(valid, info.valid.size());
  }
  for (const auto& a : Options::aliases()) alias = std::max(alias, a.alias.size());
  for (const auto& info : Options::catalogue())
    text += fmt::format("  {:<{}}  {:<{}}  {:<{}}  {}\n", info.key, key, info.default_value, value,
                        info.valid, valid, info.description);
  text += "\nRTAB-Map parameter names accepted for the setting that means the same:\n";
  for (const auto& a : Options::aliases())
    text += fmt::format("  {:<{}}  {}\n", a.alias, alias, a.key);
  return text;
}

std::string settingsJson() {
  std::map<std::string, std::vector<std::string>> aliases_of;
  for (const auto& a : Options::aliases()) aliases_of[a.key].push_back(a.alias);
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& info : Options::catalogue())
    rows.push_back({{"key", info.key},
                    {"default", info.default_value},
                    {"valid", info.valid},
                    {"description", info.description},
                    {"aliases", aliases_of[info.key]}});
  return rows.dump(2) + "\n";
}

}  // namespace placedb::cli
