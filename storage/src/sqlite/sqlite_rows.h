#pragma once
// Many rows into one SQLite table per statement. A one-row INSERT pays for its statement (the
// step, the reset, the program's start) once per row; a frame writes hundreds of rows to a table,
// so rows go in statements of kRowsPerInsert, and only those that do not fill one go one by one.
#include <cstddef>
#include <string>

#include "sqlite/database.h"

namespace placedb::storage::detail {

constexpr std::size_t kRowsPerInsert = 32;

// "<verb> INTO <into> VALUES (?, ...), ..." for `rows` rows of `columns` parameters, numbered in
// row order. `into` is "table (column, ...)"; `verb` "INSERT" or "INSERT OR IGNORE".
inline std::string multiRowInsert(const std::string& verb, const std::string& into, int columns,
                                  std::size_t rows) {
  std::string sql = verb + " INTO " + into + " VALUES ";
  for (std::size_t r = 0; r < rows; ++r) {
    sql += r ? ", (" : "(";
    for (int c = 0; c < columns; ++c) sql += c ? ", ?" : "?";
    sql += ")";
  }
  return sql;
}

// The statements for whole chunks and for single rows of one table, made once per call site.
struct RowInserts {
  RowInserts(const std::string& verb, const std::string& into, int columns)
      : columns(columns),
        many(multiRowInsert(verb, into, columns, kRowsPerInsert)),
        one(multiRowInsert(verb, into, columns, 1)) {}
  int columns;
  std::string many, one;
};

// Inserts rows [0, count): bind(statement, first, row) binds row `row`'s values at parameters
// first + 1 .. first + columns. Rows go in order, so a table's rows land as one by one would.
template <typename Bind>
void insertRows(Database& db, const RowInserts& sql, std::size_t count, const Bind& bind) {
  std::size_t row = 0;
  for (const std::string* text : {&sql.many, &sql.one}) {
    const std::size_t rows = text == &sql.many ? kRowsPerInsert : 1;
    if (row + rows > count) continue;
    auto s = db.cached(text->c_str());
    for (; row + rows <= count; row += rows) {
      for (std::size_t k = 0; k < rows; ++k) bind(*s, static_cast<int>(k) * sql.columns, row + k);
      s->run();
    }
  }
}

}  // namespace placedb::storage::detail
