// placedb check: the backend the map's name picks checks it (backends.h).
#include "placedb/storage/map_check.h"

#include "backends.h"

namespace placedb::storage {

CheckReport checkMap(const std::string& path, const CheckOptions& options) {
  if (isServerMap(path)) return checkPgMap(path, options);
  return checkSqliteMap(path, options);
}

}  // namespace placedb::storage
