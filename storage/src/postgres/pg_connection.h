#pragma once
// Internal RAII wrappers around one libpq connection: binary parameters and results, statements
// prepared once per connection, and libpq errors turned into StorageError naming the map by its
// URI without the password.
#include <cstdint>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <libpq-fe.h>

#include "placedb/storage/map_store.h"
#include "placedb/storage/storage_error.h"

namespace placedb::storage::detail {

// Parameters of one statement, every one in binary format with its type given, so nothing is
// parsed from text on the server and a double or a blob crosses exactly.
class PgParams {
 public:
  PgParams& add(std::int64_t value);
  PgParams& add(double value);
  PgParams& add(const std::string& text);
  PgParams& add(const std::optional<std::int64_t>& value);
  PgParams& add(const std::optional<double>& value);
  PgParams& addText(const std::optional<std::string>& text);
  PgParams& addBytes(const void* data, std::size_t size);
  // One-dimensional arrays, for one statement over many rows (unnest, = ANY).
  PgParams& addArray(const std::vector<std::int64_t>& values);
  PgParams& addArray(const std::vector<std::optional<std::int64_t>>& values);
  PgParams& addArray(const std::vector<double>& values);
  PgParams& addArray(const std::vector<std::string>& texts);
  PgParams& addBytesArray(const std::vector<std::pair<const void*, std::size_t>>& blobs);
  // A value of any kind, sent as the column type `target` (int8, float8, text or bytea) wants.
  PgParams& addCell(const CellValue& value, Oid target);

  int size() const { return static_cast<int>(types_.size()); }
  const std::vector<Oid>& types() const { return types_; }
  // Pointers into this object, valid while it lives unchanged.
  std::vector<const char*> values() const;
  std::vector<int> lengths() const;

 private:
  void push(Oid type, std::string bytes, bool null = false);
  void pushArray(Oid element, std::size_t count, const std::vector<std::string>* items,
                 const std::vector<bool>* nulls);

  std::vector<Oid> types_;
  std::vector<std::string> bytes_;
  std::vector<bool> nulls_;
};

// A result in binary format; columns are read by the type the server reports.
class PgResult {
 public:
  explicit PgResult(PGresult* result) : result_(result) {}
  PgResult(PgResult&& other) noexcept : result_(other.result_) { other.result_ = nullptr; }
  PgResult& operator=(PgResult&&) = delete;
  PgResult(const PgResult&) = delete;
  PgResult& operator=(const PgResult&) = delete;
  ~PgResult() { PQclear(result_); }

  int rows() const { return PQntuples(result_); }
  // Rows the command changed (UPDATE, DELETE, INSERT).
  std::int64_t changed() const;
  bool isNull(int row, int column) const { return PQgetisnull(result_, row, column) != 0; }
  std::int64_t integer(int row, int column) const;
  std::optional<std::int64_t> optionalInteger(int row, int column) const;
  double real(int row, int column) const;
  std::optional<double> optionalReal(int row, int column) const;
  std::string text(int row, int column) const;  // "" for NULL
  std::pair<const std::uint8_t*, std::size_t> bytes(int row, int column) const;
  bool boolean(int row, int column) const { return integer(row, column) != 0; }
  // The value as it is, by the column's type.
  CellValue cell(int row, int column) const;
  // Gives up ownership (the caller clears the result).
  PGresult* release() {
    PGresult* r = result_;
    result_ = nullptr;
    return r;
  }

 private:
  const char* raw(int row, int column, int* length) const;
  PGresult* result_;
};

// One connection. Transactions are driven through TransactionControl; everything else runs in
// the open transaction or on its own (autocommit).
class PgConnection final : public TransactionControl {
 public:
  // `uri` is libpq's; `label` the map's name for messages (the URI without its password).
  // Throws kServerUnreachable when no server answers, kAuthRefused when it refuses the
  // credentials, kIo when the database does not exist.
  PgConnection(const std::string& uri, std::string label, int connect_timeout_s);
  ~PgConnection() override;
  PgConnection(const PgConnection&) = delete;
  PgConnection& operator=(const PgConnection&) = delete;

  // Runs `sql` as a statement prepared on this connection at first use (one round trip after).
  PgResult run(const char* sql, const PgParams& params = PgParams());
  // For a write whose result is not needed: inside a write transaction it is sent at once
  // (libpq's pipeline mode) and its result read at the next flush(), which every other call
  // makes first (a read, the commit), so a frame's writes share round trips. Its failure is
  // thrown there, naming it. Outside a write transaction it runs at once, as run().
  void send(const char* sql, const PgParams& params = PgParams());
  // Reads the result of every statement sent; throws the first failure (pg_pipeline.cpp).
  void flush();
  // Runs one or more statements without parameters (simple query protocol), text results.
  void exec(const std::string& sql);
  // A one-off query without parameters returning one integer, text results.
  std::int64_t queryInt(const std::string& sql);

  bool inTransaction() const override;
  void beginWrite() override;
  void commit() override;
  void rollback() override;
  void rollbackQuietly() noexcept override;
  void beginRead() override;
  void endReadQuietly() noexcept override;
  const std::string& label() const override { return label_; }

 private:
  [[noreturn]] void fail(PGresult* result, const std::string& sql, const std::string& what);
  [[noreturn]] void fail(const std::string& sqlstate, const std::string& message,
                         const std::string& sql, const std::string& what);
  // The name of `sql` prepared on this connection, preparing it (sent, in pipeline mode).
  const std::string& prepare(const char* sql, const PgParams& params);
  struct Sent {
    std::string sql;
    bool prepare;  // a PQsendPrepare, whose failure means the statement is not prepared
  };
  // Reads every sent result and leaves pipeline mode; the first failure, if any, in *state,
  // *message and *sql. Never throws.
  bool drain(std::string* state, std::string* message, std::string* sql) noexcept;
  // `text` with the URI and its password replaced (by the label, by ***).
  std::string scrubbed(std::string text) const;
  PgResult check(PGresult* result, const std::string& sql, const std::string& what);

  PGconn* conn_ = nullptr;
  std::string label_;
  std::vector<std::string> secrets_;  // the URI and its password, never shown
  bool writing_ = false;              // inside a write transaction: send() pipelines
  std::vector<Sent> sent_;            // statements whose results are not read yet
  std::unordered_map<std::string, std::string> prepared_;  // SQL -> statement name
};

// Which placedb::ErrorCode a PostgreSQL SQLSTATE stands for.
ErrorCode errorCodeForSqlState(const std::string& sqlstate);

// Which placedb::ErrorCode a failed statement stands for: its SQLSTATE's, and for a failure
// without one (libpq's own, the server never answered) a lost server when the connection is down
// or libpq says it went while the statement ran (pipeline mode can report that before the
// connection's status follows).
ErrorCode errorCodeForFailure(const std::string& sqlstate, const std::string& message,
                              bool connection_ok);

}  // namespace placedb::storage::detail
