// PgMapStore: whole tables read and written as they are, for copyMap().
#include "postgres/pg_map_store.h"

#include <optional>

namespace placedb::storage {

namespace {

std::optional<std::int64_t> cellInteger(const CellValue& v) {
  if (v.kind == CellValue::Kind::kNull) return std::nullopt;
  return v.kind == CellValue::Kind::kReal ? static_cast<std::int64_t>(v.real) : v.integer;
}

double cellReal(const CellValue& v) {
  return v.kind == CellValue::Kind::kInteger ? static_cast<double>(v.integer) : v.real;
}

// The posterior's views (schema 18, migrations/pg/0018) take rows one at a time through a
// trigger that rewrites their writer's arrays: a copy appends a batch to them in one statement.
void appendPosteriorRows(detail::PgConnection& db, const std::string& label, const TableColumns& t,
                         const std::vector<TableRow>& rows) {
  const bool side = t.table == "session_posterior";
  auto column = [&](const char* name) {
    for (std::size_t c = 0; c < t.columns.size(); ++c)
      if (t.columns[c] == name) return c;
    throw StorageError(ErrorCode::kMapRefused,
                       "map " + label + " lacks column " + t.table + "." + name);
  };
  const std::size_t id = column("location_id"), p = column("probability");
  const std::size_t other = side ? column("session_id") : column("checksum");
  std::vector<std::int64_t> ids;
  std::vector<double> probabilities;
  std::vector<std::optional<std::int64_t>> others;
  for (const TableRow& row : rows) {
    const auto location = cellInteger(row[id]);
    if (!location || row[p].kind == CellValue::Kind::kNull)
      throw StorageError(ErrorCode::kMapRefused, "map " + label + ": a " + t.table +
                                                     " row has a NULL location_id or probability");
    ids.push_back(*location);
    probabilities.push_back(cellReal(row[p]));
    others.push_back(cellInteger(row[other]));
  }
  if (side) {
    db.send(
        "INSERT INTO session_posterior_vectors AS v (session_id, location_ids, probabilities) "
        "SELECT s, array_agg(i ORDER BY o), array_agg(p ORDER BY o) FROM unnest($1::int8[], "
        "$2::int8[], $3::float8[]) WITH ORDINALITY AS u(s, i, p, o) GROUP BY s ON CONFLICT "
        "(session_id) DO UPDATE SET location_ids = v.location_ids || excluded.location_ids, "
        "probabilities = v.probabilities || excluded.probabilities",
        detail::PgParams().addArray(others).addArray(ids).addArray(probabilities));
  } else {
    db.send(
        "INSERT INTO filter_posterior_vector AS v (one_row, location_ids, probabilities, "
        "checksums) SELECT true, array_agg(i ORDER BY o), array_agg(p ORDER BY o), array_agg(s "
        "ORDER BY o) FROM unnest($1::int8[], $2::float8[], $3::int8[]) WITH ORDINALITY AS u(i, "
        "p, s, o) ON CONFLICT (one_row) DO UPDATE SET location_ids = v.location_ids || "
        "excluded.location_ids, probabilities = v.probabilities || excluded.probabilities, "
        "checksums = v.checksums || excluded.checksums",
        detail::PgParams().addArray(ids).addArray(probabilities).addArray(others));
  }
}

}  // namespace

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
  if (t.table == "filter_posterior" || t.table == "session_posterior") {
    appendPosteriorRows(*db_, label_, t, rows);
    return scope.commit();
  }
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
