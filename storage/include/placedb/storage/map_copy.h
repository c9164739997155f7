#pragma once
// Copying a whole map between backends (file to server, server to file, file to file): every
// row of every table, as it is, in one transaction of the destination.
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace placedb::storage {

class MapStore;

// One value of any column: the five kinds SQLite stores, which PostgreSQL's columns take too.
struct CellValue {
  enum class Kind { kNull, kInteger, kReal, kText, kBlob };
  Kind kind = Kind::kNull;
  std::int64_t integer = 0;
  double real = 0;
  std::string bytes;  // text or blob
};
using TableRow = std::vector<CellValue>;

struct TableColumns {
  std::string table;
  std::vector<std::string> columns;  // the first ones are the primary key, rows come in its order
  int key_columns = 1;

  std::string columnList() const;        // "a, b, c", for a SELECT or an INSERT
  std::string selectInKeyOrder() const;  // every row, in primary-key order
};

// Every table of the current schema with its columns, in an order in which inserting them
// satisfies the foreign keys that are checked at once (deferred ones are checked at commit).
const std::vector<TableColumns>& mapTables();

struct CopyProgress {
  std::string table;
  std::int64_t rows = 0;
};

// Copies every row of `from` into `to`, which must be open read-write and hold no session, frame
// or word (kInvalidArgument otherwise, naming it); nothing is written unless everything is.
void copyMap(const MapStore& from, MapStore& to,
             const std::function<void(const CopyProgress&)>& progress = {});

}  // namespace placedb::storage
