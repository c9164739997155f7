// Settings from --preset, --config and --set, with their precedence and refusals.
#include <gtest/gtest.h>

#include <fstream>

#include "placedb/error.h"
#include "placedb/options.h"
#include "settings_input.h"
#include "test_paths.h"

namespace placedb::cli {
namespace {

using placedb::testing::scratchDir;

TEST(SettingsInput, PrecedencePresetThenConfigThenSet) {
  auto dir = scratchDir("SettingsInput_precedence");
  std::ofstream(dir / "a.conf") << "# comment\n t_loop = 0.3  # trailing\n\nstm_size=12\n";
  SettingsInput input;
  input.preset = "paper";
  input.config_file = (dir / "a.conf").string();
  input.assignments = {"stm_size=7"};
  Options options = resolveOptions(input);
  EXPECT_DOUBLE_EQ(options.t_loop, 0.3);  // config over preset
  EXPECT_EQ(options.stm_size, 7);         // --set over config
  // A preset value nobody overrode survives.
  EXPECT_EQ(options.decision_rule, Options::paperPreset().decision_rule);
}

TEST(SettingsInput, JsonConfig) {
  auto dir = scratchDir("SettingsInput_json");
  std::ofstream(dir / "a.json") << "{\"t_loop\": 0.25, \"word_rule\": \"nndr\", \"upright\": true}";
  Settings settings = readConfigFile(dir / "a.json");
  EXPECT_EQ(settings.at("t_loop"), "0.25");
  EXPECT_EQ(settings.at("word_rule"), "nndr");
  EXPECT_EQ(settings.at("upright"), "true");
  SettingsInput input;
  input.config_file = (dir / "a.json").string();
  EXPECT_TRUE(resolveOptions(input).upright);
}

// Found by fuzz_settings: the line form refused an empty key, the JSON form passed it on.
TEST(SettingsInput, JsonConfigWithAnEmptyKeyIsRefusedNamingTheFile) {
  auto dir = scratchDir("SettingsInput_json_empty_key");
  for (const char* text : {"{\"\": -88.12}", "{\"t_loop\": 0.2, \"  \": 1}"}) {
    std::ofstream(dir / "a.json", std::ios::trunc) << text;
    try {
      readConfigFile(dir / "a.json");
      ADD_FAILURE() << text << " was accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument) << e.what();
      EXPECT_NE(std::string(e.what()).find("a.json"), std::string::npos) << e.what();
    }
  }
}

TEST(SettingsInput, RefusesUnknownKeysBadValuesAndMalformedInput) {
  auto code = [](const SettingsInput& input) {
    try {
      resolveOptions(input);
    } catch (const Error& e) {
      return e.code();
    }
    return ErrorCode::kInternal;
  };
  SettingsInput unknown;
  unknown.assignments = {"no_such_key=1"};
  EXPECT_EQ(code(unknown), ErrorCode::kInvalidArgument);
  try {
    resolveOptions(unknown);
  } catch (const Error& e) {
    // The refusal lists the valid keys.
    EXPECT_NE(std::string(e.what()).find("t_loop"), std::string::npos) << e.what();
  }
  SettingsInput bad_value;
  bad_value.assignments = {"t_loop=abc"};
  EXPECT_EQ(code(bad_value), ErrorCode::kInvalidArgument);
  SettingsInput no_equals;
  no_equals.assignments = {"t_loop"};
  EXPECT_EQ(code(no_equals), ErrorCode::kInvalidArgument);
  SettingsInput bad_preset;
  bad_preset.preset = "fastest";
  EXPECT_EQ(code(bad_preset), ErrorCode::kInvalidArgument);
  SettingsInput missing_config;
  missing_config.config_file = "/nonexistent/placedb.conf";
  EXPECT_EQ(code(missing_config), ErrorCode::kIo);
}

TEST(SettingsInput, RtabmapParameterNamesAreAliases) {
  SettingsInput input;
  input.assignments = {"Rtabmap/LoopThr=0.2", "Mem/STMSize=12", "SURF/Upright=true"};
  Options options = resolveOptions(input);
  EXPECT_DOUBLE_EQ(options.t_loop, 0.2);
  EXPECT_EQ(options.stm_size, 12);
  EXPECT_TRUE(options.upright);
  // Stored and printed under our own keys.
  EXPECT_EQ(options.toSettings().count("Rtabmap/LoopThr"), 0u);
  EXPECT_EQ(options.toSettings().at("t_loop"), "0.2");
  // The same setting under both names is ambiguous.
  input.assignments = {"Rtabmap/LoopThr=0.2", "t_loop=0.3"};
  try {
    resolveOptions(input);
    ADD_FAILURE() << "t_loop given twice was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find("given twice"), std::string::npos) << e.what();
  }
  // Every alias names a real setting.
  for (const auto& alias : Options::aliases())
    EXPECT_NO_THROW(Options::fromSettings({{alias.key, Options().toSettings().at(alias.key)}}))
        << alias.alias;
}

// The word index is placedb's own kd-forest; the help must not name a library it does not link.
TEST(SettingsInput, HelpNamesNoLibraryPlacedbDoesNotUse) {
  const std::string help = settingsHelp();
  EXPECT_EQ(help.find("FLANN"), std::string::npos) << help;
  EXPECT_NE(help.find("kd_trees"), std::string::npos) << help;
}

// Every setting's default starts in one column, however long the longest key.
TEST(SettingsInput, HelpColumnsLineUp) {
  const std::string help = settingsHelp();
  std::size_t column = std::string::npos;
  for (const auto& info : Options::catalogue()) {
    const auto at = help.find("\n  " + info.key + " ");
    ASSERT_NE(at, std::string::npos) << info.key;
    const std::size_t line = at + 1;
    const std::size_t value = help.find_first_not_of(' ', line + 2 + info.key.size()) - line;
    if (column == std::string::npos) column = value;
    EXPECT_EQ(value, column) << info.key;
  }
}

}  // namespace
}  // namespace placedb::cli
