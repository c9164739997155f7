// RTAB-Map's parameter names (Parameters.h) for the settings whose meaning and unit are the
// same in placedb, so that an RTAB-Map configuration's values carry over. A parameter whose
// meaning differs (its likelihood, its detector strategy numbers) has no alias.
#include "api/setting_aliases.h"

#include <fmt/format.h>

#include "placedb/error.h"
#include "placedb/options.h"

namespace placedb {

std::vector<Options::SettingAlias> Options::aliases() {
  return {
      {"Rtabmap/LoopThr", "t_loop"},
      {"Rtabmap/LoopRatio", "loop_ratio"},
      {"Rtabmap/TimeThr", "t_time_ms"},
      {"Rtabmap/MemoryThr", "wm_max"},
      {"Rtabmap/MaxRetrieved", "max_retrieved"},
      {"Mem/STMSize", "stm_size"},
      {"Mem/RehearsalSimilarity", "t_sim"},
      {"Kp/MaxFeatures", "max_features"},
      {"Kp/NndrRatio", "t_nndr"},
      {"Kp/BadSignRatio", "bad_ratio"},
      {"SURF/HessianThreshold", "hessian_threshold"},
      {"SURF/Octaves", "octaves"},
      {"SURF/OctaveLayers", "intervals"},
      {"SURF/Upright", "upright"},
      {"Vis/MinInliers", "geometry_min_inliers"},
  };
}

std::map<std::string, std::string> withAliasesResolved(
    const std::map<std::string, std::string>& settings) {
  std::map<std::string, std::string> key_of;
  for (const auto& a : Options::aliases()) key_of[a.alias] = a.key;
  std::map<std::string, std::string> resolved;
  std::map<std::string, std::string> given_as;  // key -> the name it was given under
  for (const auto& [name, value] : settings) {
    const auto alias = key_of.find(name);
    const std::string& key = alias == key_of.end() ? name : alias->second;
    const auto [at, inserted] = given_as.emplace(key, name);
    if (!inserted)
      throw Error(
          ErrorCode::kInvalidArgument,
          fmt::format("setting '{}' is given twice, as '{}' and as '{}'", key, at->second, name));
    resolved[key] = value;
  }
  return resolved;
}

}  // namespace placedb
