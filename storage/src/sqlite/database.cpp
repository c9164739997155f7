#include "sqlite/database.h"

#include <sys/resource.h>
#include <sys/statvfs.h>

#include <cerrno>
#include <filesystem>
#include <limits>

#include "placedb/storage/map_files.h"

namespace placedb::storage {

ErrorCode errorCodeForSqlite(int sqlite_code) noexcept {
  switch (sqlite_code & 0xff) {
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
      return ErrorCode::kMapBusy;
    case SQLITE_FULL:
      return ErrorCode::kDiskFull;
    case SQLITE_READONLY:
      return ErrorCode::kReadOnly;
    case SQLITE_NOTADB:
    case SQLITE_CORRUPT:
      return ErrorCode::kMapRefused;
    case SQLITE_CANTOPEN:
    case SQLITE_IOERR:
      return ErrorCode::kIo;
    default:
      return ErrorCode::kStorage;
  }
}

namespace detail {
namespace {

// SQLite's errno is not reliable after a failed write: the unix VFS keeps the write's errno on
// the file and sqlite3_system_errno() reports whatever errno holds when the error surfaces
// (often after a rollback's own calls). So look at the cause itself: a folder with almost no
// free space, or a map or write-ahead log that reached the process' file-size limit.
bool outOfRoom(const char* map_file) {
  if (!map_file || !*map_file) return false;
  const std::filesystem::path map(map_file);
  constexpr std::uint64_t kSlack = 1 << 20;  // more than a transaction's worth of pages
  struct statvfs fs {};
  if (statvfs(map.parent_path().empty() ? "." : map.parent_path().c_str(), &fs) == 0 &&
      std::uint64_t{fs.f_bavail} * fs.f_frsize < kSlack)
    return true;
  rlimit limit{};
  if (getrlimit(RLIMIT_FSIZE, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return false;
  for (const std::string& file : mapFiles(map.string())) {
    std::error_code error;
    const auto size = std::filesystem::file_size(file, error);
    if (!error && size + kSlack >= limit.rlim_cur) return true;
  }
  return false;
}

}  // namespace

void throwSqlite(sqlite3* db, int rc, const std::string& sql, const std::string& what) {
  const int extended = db ? sqlite3_extended_errcode(db) : rc;
  const int code = (extended & 0xff) == (rc & 0xff) ? extended : rc;
  const std::string sqlite_message = db ? sqlite3_errmsg(db) : sqlite3_errstr(rc);
  std::string message =
      what + ": " + sqlite_message + " (SQLite code " + std::to_string(code) + ")";
  if (!sql.empty()) message += " in statement: " + sql;
  // Name the map: the message may reach a user far from the open() that named it.
  if (const char* file = db ? sqlite3_db_filename(db, "main") : nullptr; file && *file)
    message += std::string(" (map ") + file + ")";
  ErrorCode placedb_code = errorCodeForSqlite(code);
  // A write refused by the file system for lack of space or a file-size limit reaches SQLite
  // as an I/O error; the user needs to hear "disk full", not "I/O".
  if ((code & 0xff) == SQLITE_IOERR && db) {
    const int os_error = sqlite3_system_errno(db);
    if (os_error == ENOSPC || os_error == EFBIG || os_error == EDQUOT ||
        (code != SQLITE_IOERR_READ && code != SQLITE_IOERR_SHORT_READ &&
         outOfRoom(sqlite3_db_filename(db, "main"))))
      placedb_code = ErrorCode::kDiskFull;
  }
  throw StorageError(placedb_code, message, code, sqlite_message, sql);
}

Statement::Statement(sqlite3* db, std::string sql) : db_(db), sql_(std::move(sql)) {
  const int rc = sqlite3_prepare_v3(db_, sql_.c_str(), static_cast<int>(sql_.size()),
                                    SQLITE_PREPARE_PERSISTENT, &stmt_, nullptr);
  if (rc != SQLITE_OK) throwSqlite(db_, rc, sql_, "cannot prepare statement");
}

Statement::~Statement() { sqlite3_finalize(stmt_); }

void Statement::reset() {
  // The error of a failed step is reported by step(); reset repeats it, so it is ignored here.
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
}

void Statement::check(int rc, const char* what) const {
  if (rc != SQLITE_OK) throwSqlite(db_, rc, sql_, what);
}

void Statement::bind(int index, std::int64_t value) {
  check(sqlite3_bind_int64(stmt_, index, value), "cannot bind integer");
}
void Statement::bind(int index, double value) {
  check(sqlite3_bind_double(stmt_, index, value), "cannot bind real");
}
void Statement::bind(int index, const std::string& value) {
  check(sqlite3_bind_text(stmt_, index, value.data(), static_cast<int>(value.size()),
                          SQLITE_TRANSIENT),
        "cannot bind text");
}
void Statement::bind(int index, const std::optional<std::int64_t>& value) {
  if (value)
    bind(index, *value);
  else
    bindNull(index);
}
void Statement::bind(int index, const std::optional<double>& value) {
  if (value)
    bind(index, *value);
  else
    bindNull(index);
}
void Statement::bindBlob(int index, const void* data, std::size_t size) {
  if (size > static_cast<std::size_t>(std::numeric_limits<int>::max())) {
    throw StorageError(ErrorCode::kInvalidArgument, "blob too large for SQLite", 0, {}, sql_);
  }
  // SQLite would store a null pointer as NULL; an empty blob must stay a blob.
  static const unsigned char kEmpty = 0;
  check(
      sqlite3_bind_blob(stmt_, index, data ? data : &kEmpty, static_cast<int>(size), SQLITE_STATIC),
      "cannot bind blob");
}
void Statement::bindNull(int index) { check(sqlite3_bind_null(stmt_, index), "cannot bind null"); }

bool Statement::step() {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  throwSqlite(db_, rc, sql_, "statement failed");
}

void Statement::run() {
  while (step()) {
  }
  reset();
}

bool Statement::isNull(int column) const {
  return sqlite3_column_type(stmt_, column) == SQLITE_NULL;
}
std::int64_t Statement::columnInt(int column) const { return sqlite3_column_int64(stmt_, column); }
double Statement::columnDouble(int column) const { return sqlite3_column_double(stmt_, column); }
std::string Statement::columnText(int column) const {
  const auto* text = sqlite3_column_text(stmt_, column);
  const int size = sqlite3_column_bytes(stmt_, column);
  return text ? std::string(reinterpret_cast<const char*>(text), size) : std::string();
}
std::vector<std::uint8_t> Statement::columnBlob(int column) const {
  const auto* data = static_cast<const std::uint8_t*>(sqlite3_column_blob(stmt_, column));
  const int size = sqlite3_column_bytes(stmt_, column);
  return data ? std::vector<std::uint8_t>(data, data + size) : std::vector<std::uint8_t>();
}
std::pair<const std::uint8_t*, std::size_t> Statement::columnBlobView(int column) const {
  const auto* data = static_cast<const std::uint8_t*>(sqlite3_column_blob(stmt_, column));
  return {data, data ? static_cast<std::size_t>(sqlite3_column_bytes(stmt_, column)) : 0};
}
std::optional<std::int64_t> Statement::columnOptionalInt(int column) const {
  if (isNull(column)) return std::nullopt;
  return columnInt(column);
}
std::optional<double> Statement::columnOptionalDouble(int column) const {
  if (isNull(column)) return std::nullopt;
  return columnDouble(column);
}

Database::Database(const std::string& filename, int flags) : label_(filename) {
  const int rc = sqlite3_open_v2(filename.c_str(), &db_, flags, nullptr);
  if (rc != SQLITE_OK) {
    // Copy the message before closing, because the handle owns it.
    try {
      throwSqlite(db_, rc, {}, "cannot open " + filename);
    } catch (...) {
      sqlite3_close(db_);
      throw;
    }
  }
  sqlite3_extended_result_codes(db_, 1);
}

Database::~Database() {
  statements_.clear();  // finalize before close, or close would fail with SQLITE_BUSY
  sqlite3_close(db_);
}

void Database::exec(const std::string& sql) {
  char* error = nullptr;
  const int rc = sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error);
  sqlite3_free(error);  // sqlite3_errmsg still holds the message
  if (rc != SQLITE_OK) throwSqlite(db_, rc, sql, "on " + label_);
}

std::int64_t Database::queryInt(const std::string& sql) {
  Statement statement(db_, sql);
  if (!statement.step()) return 0;
  return statement.columnInt(0);
}

std::string Database::queryText(const std::string& sql) {
  Statement statement(db_, sql);
  if (!statement.step()) return {};
  return statement.columnText(0);
}

StatementUse Database::cached(const char* sql) {
  auto found = statements_.find(sql);
  if (found == statements_.end()) {
    found = statements_.emplace(sql, std::make_unique<Statement>(db_, sql)).first;
  }
  return StatementUse(*found->second);
}

void Database::beginWrite() {
  try {
    exec("BEGIN IMMEDIATE");
  } catch (const StorageError& error) {
    if (error.code() != ErrorCode::kMapBusy) throw;
    throw StorageError(ErrorCode::kMapBusy,
                       "map " + label_ +
                           " is busy: another connection holds a write transaction and did not "
                           "finish within the busy timeout",
                       error.sqliteCode(), error.sqliteMessage(), error.sql());
  }
}

void Database::commit() {
  try {
    exec("COMMIT");
  } catch (...) {
    // A failed COMMIT (deferred foreign key, disk full) may leave the transaction open; the frame
    // must then vanish as a whole.
    rollbackQuietly();
    throw;
  }
}

void Database::rollback() {
  ++rollbacks_;
  if (inTransaction()) exec("ROLLBACK");
}

void Database::rollbackQuietly() noexcept {
  ++rollbacks_;
  if (inTransaction()) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
}

void Database::beginRead() { exec("BEGIN DEFERRED"); }

void Database::endReadQuietly() noexcept {
  if (inTransaction()) sqlite3_exec(db_, "COMMIT", nullptr, nullptr, nullptr);
}

}  // namespace detail
}  // namespace placedb::storage
