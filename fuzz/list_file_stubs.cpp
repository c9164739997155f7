// The bag and live sources ImageSource::open reaches, for fuzz_list_file only: the list parser it
// fuzzes never opens a source, so these are never called (and abort if they were).
#include <cstdlib>
#include <memory>
#include <string>

#include "sources/bag_source.h"
#include "sources/live_source.h"

namespace placedb::cli {

bool isLiveSource(const std::string&) { std::abort(); }
std::unique_ptr<ImageSource> openLiveSource(const std::string&, double) { std::abort(); }
bool isBag(const std::string&) { std::abort(); }
std::unique_ptr<ImageSource> openBag(const std::string&, const std::string&) { std::abort(); }

}  // namespace placedb::cli
