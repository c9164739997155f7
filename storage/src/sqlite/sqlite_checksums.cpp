// The row checksums (row_checksums.h) as SQLite reads and fills them.
#include "sqlite/sqlite_checksums.h"

#include <string>
#include <utility>
#include <vector>

#include "sqlite/database.h"

namespace placedb::storage::detail {

bool checksumMatches(const Statement& row, int column, std::uint32_t computed) {
  return !row.isNull(column) && row.columnInt(column) == std::int64_t{computed};
}

void fillChecksums(Database& db) {
  // Sums are gathered first and written after each scan, so no table is changed under a read.
  std::vector<std::pair<std::int64_t, std::int64_t>> by_id;
  {
    Statement read(db.handle(),
                   "SELECT id, created_frame, descriptor_type, dim, descriptor FROM words");
    while (read.step()) {
      const auto [data, size] = read.columnBlobView(4);
      by_id.emplace_back(read.columnInt(0),
                         wordChecksum(read.columnInt(0), read.columnOptionalInt(1),
                                      read.columnInt(2), read.columnInt(3), data, size));
    }
    Statement write(db.handle(), "UPDATE words SET checksum = ?2 WHERE id = ?1");
    for (const auto& [id, sum] : by_id) {
      write.bind(1, id);
      write.bind(2, sum);
      write.run();
    }
  }
  by_id.clear();
  {
    Statement read(db.handle(), "SELECT location_id, code FROM place_codes");
    while (read.step()) {
      const auto [data, size] = read.columnBlobView(1);
      by_id.emplace_back(read.columnInt(0), placeCodeChecksum(read.columnInt(0), data, size));
    }
    Statement write(db.handle(), "UPDATE place_codes SET checksum = ?2 WHERE location_id = ?1");
    for (const auto& [id, sum] : by_id) {
      write.bind(1, id);
      write.bind(2, sum);
      write.run();
    }
  }
  {
    std::vector<std::pair<std::string, std::int64_t>> by_key;
    Statement read(db.handle(), "SELECT key, value FROM engine_state");
    while (read.step()) {
      const std::string key = read.columnText(0);
      const auto [data, size] = read.columnBlobView(1);
      by_key.emplace_back(key, stateChecksum(key, data, size));
    }
    Statement write(db.handle(), "UPDATE engine_state SET checksum = ?2 WHERE key = ?1");
    for (const auto& [key, sum] : by_key) {
      write.bind(1, key);
      write.bind(2, sum);
      write.run();
    }
  }
  {
    struct Row {
      std::int64_t tree, node, sum;
    };
    std::vector<Row> rows;
    Statement read(db.handle(),
                   "SELECT tree, node, left_child, right_child, split_dim, split_value "
                   "FROM kd_nodes");
    while (read.step())
      rows.push_back({read.columnInt(0), read.columnInt(1),
                      kdNodeChecksum(read.columnInt(0), read.columnInt(1), read.columnInt(2),
                                     read.columnInt(3), read.columnInt(4), read.columnDouble(5))});
    Statement write(db.handle(), "UPDATE kd_nodes SET checksum = ?3 WHERE tree = ?1 AND node = ?2");
    for (const Row& r : rows) {
      write.bind(1, r.tree);
      write.bind(2, r.node);
      write.bind(3, r.sum);
      write.run();
    }
  }
  const std::string rows = std::to_string(db.queryInt("SELECT count(*) FROM kd_nodes"));
  Statement put(db.handle(), "INSERT INTO engine_state (key, value, checksum) VALUES (?1, ?2, ?3)");
  put.bind(1, std::string(kKdNodeRowsKey));
  put.bind(2, rows);
  put.bind(3, std::int64_t{stateChecksum(kKdNodeRowsKey, rows.data(), rows.size())});
  put.run();
}

}  // namespace placedb::storage::detail
