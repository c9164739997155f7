#pragma once
// Internal RAII wrappers around one SQLite connection and its prepared statements.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include <sqlite3.h>

#include "placedb/storage/map_store.h"
#include "placedb/storage/storage_error.h"

namespace placedb::storage::detail {

// Throws StorageError for a failed SQLite call; `sql` names the statement, `what` the action.
[[noreturn]] void throwSqlite(sqlite3* db, int rc, const std::string& sql, const std::string& what);

class Statement {
 public:
  Statement(sqlite3* db, std::string sql);
  ~Statement();
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  // Back to the start with every parameter NULL, so a reused statement never sees stale values.
  void reset();

  void bind(int index, std::int64_t value);
  void bind(int index, double value);
  void bind(int index, const std::string& value);
  void bind(int index, const std::optional<std::int64_t>& value);
  void bind(int index, const std::optional<double>& value);
  void bindBlob(int index, const void* data, std::size_t size);
  void bindNull(int index);

  // True while rows come, false when done; throws StorageError on failure.
  bool step();
  // Runs a statement that returns no rows, then resets it.
  void run();

  bool isNull(int column) const;
  std::int64_t columnInt(int column) const;
  double columnDouble(int column) const;
  std::string columnText(int column) const;
  std::vector<std::uint8_t> columnBlob(int column) const;
  // The blob in place, valid until the next step or reset: for bulk loads that copy it anyway.
  std::pair<const std::uint8_t*, std::size_t> columnBlobView(int column) const;
  std::optional<std::int64_t> columnOptionalInt(int column) const;
  std::optional<double> columnOptionalDouble(int column) const;

  const std::string& sql() const { return sql_; }
  sqlite3_stmt* handle() const { return stmt_; }

 private:
  void check(int rc, const char* what) const;

  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
  std::string sql_;
};

// A cached statement in use; resets it on scope exit so it holds no read snapshot afterwards.
class StatementUse {
 public:
  explicit StatementUse(Statement& statement) : statement_(&statement) { statement_->reset(); }
  ~StatementUse() { statement_->reset(); }
  StatementUse(const StatementUse&) = delete;
  StatementUse& operator=(const StatementUse&) = delete;
  Statement* operator->() const { return statement_; }
  Statement& operator*() const { return *statement_; }

 private:
  Statement* statement_;
};

class Database final : public TransactionControl {
 public:
  // flags as sqlite3_open_v2; the file name may be a URI when SQLITE_OPEN_URI is set.
  Database(const std::string& filename, int flags);
  ~Database() override;
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  sqlite3* handle() const { return db_; }
  // Runs one or more statements with no results.
  void exec(const std::string& sql);
  std::int64_t queryInt(const std::string& sql);
  std::string queryText(const std::string& sql);
  // The statement for `sql`, prepared on first use and kept for the connection's life.
  StatementUse cached(const char* sql);
  bool inTransaction() const override { return sqlite3_get_autocommit(db_) == 0; }

  // TransactionControl: BEGIN IMMEDIATE (kMapBusy after the busy timeout), COMMIT, ROLLBACK;
  // reads under BEGIN DEFERRED.
  void beginWrite() override;
  void commit() override;
  void rollback() override;
  void rollbackQuietly() noexcept override;
  void beginRead() override;
  void endReadQuietly() noexcept override;
  // How many times a transaction was (or may have been) rolled back on this connection: a change
  // kept in RAM beside the file is stale when this moved since it was made.
  std::uint64_t rollbacks() const { return rollbacks_; }

  // Shown in error messages (the map path).
  void setLabel(std::string label) { label_ = std::move(label); }
  const std::string& label() const override { return label_; }

 private:
  sqlite3* db_ = nullptr;
  std::string label_;
  std::unordered_map<std::string, std::unique_ptr<Statement>> statements_;
  std::uint64_t rollbacks_ = 0;
};

}  // namespace placedb::storage::detail
