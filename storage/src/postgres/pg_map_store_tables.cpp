// PgMapStore: whole tables read and written as they are, for copyMap().
#include "postgres/pg_map_store.h"

namespace placedb::storage {

void PgMapStore::readTable(const TableColumns& t,
                           const std::function<void(const TableRow&)>& row) const {
  // One result in memory: the largest table of a map (word_refs) is a few hundred MB at most
  // for a day's mapping; a cursor would be the next step for larger ones.
  const std::string sql = t.selectInKeyOrder();
  const auto r = db_->run(sql.c_str());
  TableRow values(t.columns.size());
  for (int i = 0; i < r.rows(); ++i) {
    for (std::size_t c = 0; c < t.columns.size(); ++c) values[c] = r.cell(i, static_cast<int>(c));
    row(values);
  }
}

void PgMapStore::writeRows(const TableColumns& t, const std::vector<TableRow>& rows) {
  auto scope = writeScope();
  if (rows.empty()) return scope.commit();
  // Each column's type, so that every value is sent as its column wants it (a SQLite map may
  // hold text where this one holds bytea, an integer where it holds a double).
  const auto types = db_->run(
      "SELECT attname, atttypid::int8 FROM pg_attribute WHERE attrelid = to_regclass($1) AND "
      "attnum > 0 AND NOT attisdropped",
      detail::PgParams().add(t.table));
  std::vector<Oid> target(t.columns.size(), 0);
  for (int i = 0; i < types.rows(); ++i)
    for (std::size_t c = 0; c < t.columns.size(); ++c)
      if (t.columns[c] == types.text(i, 0)) target[c] = static_cast<Oid>(types.integer(i, 1));
  for (std::size_t c = 0; c < t.columns.size(); ++c)
    if (target[c] == 0)
      throw StorageError(ErrorCode::kMapRefused,
                         "map " + label_ + " lacks column " + t.table + "." + t.columns[c]);
  // One multi-row INSERT per batch: a round trip per batch, not per row.
  std::string sql = "INSERT INTO " + t.table + " (" + t.columnList() + ") VALUES ";
  detail::PgParams params;
  int n = 0;
  for (std::size_t r = 0; r < rows.size(); ++r) {
    sql += r ? ", (" : "(";
    for (std::size_t c = 0; c < t.columns.size(); ++c) {
      sql += (c ? ", $" : "$") + std::to_string(++n);
      params.addCell(rows[r][c], target[c]);
    }
    sql += ")";
  }
  db_->send(sql.c_str(), params);
  scope.commit();
}

}  // namespace placedb::storage
