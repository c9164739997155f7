#pragma once
// What the shared room asks of each backend: the entry points the factory (map_store.cpp) and
// the check (map_check.cpp) pick between by the map's name. Declared here, defined in sqlite/ and
// postgres/, so that the shared room includes neither backend and neither backend the other.
#include <memory>
#include <string>

#include "placedb/storage/check_report.h"
#include "placedb/storage/map_store.h"

namespace placedb::storage {

// postgres/pg_map_store.cpp: a map in a database on a server, named by a libpq URI.
std::unique_ptr<MapStore> openPgMapStore(const std::string& uri, OpenMode mode,
                                         const OpenOptions& options);

// sqlite/sqlite_map_check.cpp: pages, keys, checksums and values of a map file.
CheckReport checkSqliteMap(const std::string& path, const CheckOptions& options);
// postgres/pg_map_check.cpp: checksums, counts and values in one read-only snapshot.
CheckReport checkPgMap(const std::string& uri, const CheckOptions& options);

}  // namespace placedb::storage
