#pragma once
// RTAB-Map parameter names as aliases of placedb settings (Options::aliases()).
#include <map>
#include <string>

namespace placedb {

// The settings with every alias replaced by its key. Throws placedb::Error(kInvalidArgument)
// when a setting is given twice, under its key and an alias or under two aliases.
std::map<std::string, std::string> withAliasesResolved(
    const std::map<std::string, std::string>& settings);

}  // namespace placedb
