#pragma once
// A whole-map check for a user who wants to know before a mission: SQLite's own integrity check
// (on a connection that could write, where CHECK constraints are verified too), foreign keys,
// and every row checksum and stored count of schema 8. It never writes: the map and its -wal
// file are left as they were found.
#include <string>

#include "placedb/storage/check_report.h"

namespace placedb::storage {

// Throws StorageError: kIo when the file is missing or unreadable, kMapRefused when it is not a
// placedb map this binary can open (not SQLite, another application's, newer schema). Damage is
// reported in the result, not thrown.
// A map on a PostgreSQL server (a URI) gets the checksum, count and value checks; its pages and
// keys are the server's (see schema/SCHEMA.md).
CheckReport checkMap(const std::string& path, const CheckOptions& options = {});

}  // namespace placedb::storage
