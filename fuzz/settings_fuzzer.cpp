// libFuzzer target: the settings a user types, read from a config file's content
// (tools/src/settings_input.cpp, placedb::cli::parseConfig: `key = value` lines or one JSON
// object) and checked by the catalogue (Options::fromSettings). The contract: a placedb::Error of
// kind kInvalidArgument naming the file or the key (from the parser, fromSettings or validate),
// or Options that survive a round trip through their own settings unchanged.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "placedb/error.h"
#include "placedb/options.h"
#include "settings_input.h"

namespace {

void check(bool ok) {
  if (!ok) std::abort();
}

const char* const kName = "fuzz.conf";

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string content(reinterpret_cast<const char*>(data), size);
  placedb::cli::Settings settings;
  try {
    settings = placedb::cli::parseConfig(content, kName);
  } catch (const placedb::Error& e) {
    check(e.code() == placedb::ErrorCode::kInvalidArgument);
    check(std::string(e.what()).find(kName) != std::string::npos);
    return 0;
  }
  for (const auto& [key, value] : settings) check(!key.empty());
  placedb::Options options;
  try {
    options = placedb::Options::fromSettings(settings);
    // The checks between keys (t_nd1 <= t_nd2, the intrinsics given together, ...) are
    // validate()'s, as the command line runs them next: a refusal there is the same clean error.
    options.validate();
  } catch (const placedb::Error& e) {
    check(e.code() == placedb::ErrorCode::kInvalidArgument);
    return 0;
  }
  const auto written = options.toSettings();
  check(placedb::Options::fromSettings(written).toSettings() == written);
  return 0;
}
