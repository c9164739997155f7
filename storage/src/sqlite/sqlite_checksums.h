#pragma once
// The row checksums of row_checksums.h on SQLite's rows: comparing a column with its sum, and
// filling the sums of a map upgraded to schema 8.
#include <cstdint>

#include "row_checksums.h"

namespace placedb::storage::detail {

class Database;
class Statement;

// True when column `column` of the current row holds `computed` (a NULL never matches: every row
// of a schema-8 map has its sum).
bool checksumMatches(const Statement& row, int column, std::uint32_t computed);

// Fills the checksum of every row of an upgraded map and writes kKdNodeRowsKey; runs inside the
// schema-8 migration's transaction.
void fillChecksums(Database& db);

}  // namespace placedb::storage::detail
