#include "map_rows.h"

#include <sqlite3.h>

#include <filesystem>
#include <memory>

#include "placedb/error.h"
#include "placedb/storage/map_store.h"

namespace py = pybind11;

namespace placedb::python {
namespace {

struct CloseDatabase {
  void operator()(sqlite3* db) const { sqlite3_close(db); }
};
struct FinalizeStatement {
  void operator()(sqlite3_stmt* statement) const { sqlite3_finalize(statement); }
};

py::object columnValue(sqlite3_stmt* statement, int column) {
  switch (sqlite3_column_type(statement, column)) {
    case SQLITE_INTEGER:
      return py::int_(sqlite3_column_int64(statement, column));
    case SQLITE_FLOAT:
      return py::float_(sqlite3_column_double(statement, column));
    case SQLITE_TEXT:
      return py::str(reinterpret_cast<const char*>(sqlite3_column_text(statement, column)));
    case SQLITE_BLOB:
      return py::bytes(static_cast<const char*>(sqlite3_column_blob(statement, column)),
                       static_cast<std::size_t>(sqlite3_column_bytes(statement, column)));
    default:
      return py::none();
  }
}

}  // namespace

namespace {

// A map on a server: the view through the store (its rows as copyMap reads a table).
py::list serverLoopClosureRows(const std::string& uri) {
  const auto store = storage::openMapStore(uri, storage::OpenMode::kReadOnly);
  const storage::TableColumns view{"v_loop_closures",
                                   {"location_a", "location_b", "score", "first_frame_a",
                                    "first_frame_b", "session_a", "session_b"},
                                   2};
  py::list rows;
  store->readTable(view, [&](const storage::TableRow& values) {
    py::dict row;
    for (std::size_t c = 0; c < values.size(); ++c) {
      const storage::CellValue& v = values[c];
      py::object value = py::none();
      if (v.kind == storage::CellValue::Kind::kInteger) value = py::int_(v.integer);
      if (v.kind == storage::CellValue::Kind::kReal) value = py::float_(v.real);
      if (v.kind == storage::CellValue::Kind::kText) value = py::str(v.bytes);
      if (v.kind == storage::CellValue::Kind::kBlob) value = py::bytes(v.bytes);
      row[py::str(view.columns[c])] = value;
    }
    rows.append(row);
  });
  return rows;
}

}  // namespace

py::list loopClosureRows(const std::string& path) {
  if (storage::isServerMap(path)) return serverLoopClosureRows(path);
  if (!std::filesystem::exists(path))
    throw Error(ErrorCode::kIo, "map " + path + " does not exist");
  sqlite3* raw = nullptr;
  const int opened = sqlite3_open_v2(path.c_str(), &raw, SQLITE_OPEN_READONLY, nullptr);
  std::unique_ptr<sqlite3, CloseDatabase> db(raw);
  if (opened != SQLITE_OK) throw Error(ErrorCode::kIo, "cannot open map " + path);
  sqlite3_busy_timeout(db.get(), 5000);  // a mapping run commits one short transaction a frame
  sqlite3_stmt* prepared = nullptr;
  if (sqlite3_prepare_v2(db.get(), "SELECT * FROM v_loop_closures", -1, &prepared, nullptr) !=
      SQLITE_OK) {
    throw Error(ErrorCode::kMapRefused, "map " + path + " refused: " + sqlite3_errmsg(db.get()));
  }
  std::unique_ptr<sqlite3_stmt, FinalizeStatement> statement(prepared);
  py::list rows;
  const int columns = sqlite3_column_count(statement.get());
  int step;
  while ((step = sqlite3_step(statement.get())) == SQLITE_ROW) {
    py::dict row;
    for (int c = 0; c < columns; ++c)
      row[py::str(sqlite3_column_name(statement.get(), c))] = columnValue(statement.get(), c);
    rows.append(row);
  }
  if (step != SQLITE_DONE)
    throw Error(ErrorCode::kStorage, "map " + path + ": " + sqlite3_errmsg(db.get()));
  return rows;
}

}  // namespace placedb::python
