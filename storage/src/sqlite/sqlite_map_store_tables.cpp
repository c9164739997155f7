// SqliteMapStore: whole tables read and written as they are, for copyMap().
#include "placedb/storage/sqlite_map_store.h"
#include "sqlite/database.h"

namespace placedb::storage {

void SqliteMapStore::readTable(const TableColumns& t,
                               const std::function<void(const TableRow&)>& row) const {
  detail::Statement s(db_->handle(), t.selectInKeyOrder());
  TableRow values(t.columns.size());
  while (s.step()) {
    for (std::size_t i = 0; i < t.columns.size(); ++i) {
      CellValue& v = values[i];
      const int column = static_cast<int>(i);
      switch (sqlite3_column_type(s.handle(), column)) {
        case SQLITE_NULL:
          v = {};
          break;
        case SQLITE_INTEGER:
          v = {CellValue::Kind::kInteger, s.columnInt(column), 0, {}};
          break;
        case SQLITE_FLOAT:
          v = {CellValue::Kind::kReal, 0, s.columnDouble(column), {}};
          break;
        case SQLITE_TEXT:
          v = {CellValue::Kind::kText, 0, 0, s.columnText(column)};
          break;
        default: {
          const auto [data, size] = s.columnBlobView(column);
          v = {CellValue::Kind::kBlob, 0, 0,
               std::string(reinterpret_cast<const char*>(data), size)};
        }
      }
    }
    row(values);
  }
}

void SqliteMapStore::writeRows(const TableColumns& t, const std::vector<TableRow>& rows) {
  auto scope = writeScope();
  std::string marks;
  for (std::size_t i = 0; i < t.columns.size(); ++i) marks += (i ? ", ?" : "?");
  detail::Statement s(
      db_->handle(), "INSERT INTO " + t.table + " (" + t.columnList() + ") VALUES (" + marks + ")");
  for (const TableRow& row : rows) {
    for (std::size_t i = 0; i < row.size(); ++i) {
      const int index = static_cast<int>(i) + 1;
      const CellValue& v = row[i];
      switch (v.kind) {
        case CellValue::Kind::kNull:
          s.bindNull(index);
          break;
        case CellValue::Kind::kInteger:
          s.bind(index, v.integer);
          break;
        case CellValue::Kind::kReal:
          s.bind(index, v.real);
          break;
        case CellValue::Kind::kText:
          s.bind(index, v.bytes);
          break;
        case CellValue::Kind::kBlob:
          s.bindBlob(index, v.bytes.data(), v.bytes.size());
          break;
      }
    }
    s.run();
  }
  scope.commit();
}

}  // namespace placedb::storage
