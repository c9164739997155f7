#pragma once
// The error every failing SQLite call turns into: a placedb::Error whose code says what the
// caller can do about it, plus SQLite's own code and message and the SQL that failed.
#include <string>

#include "placedb/error.h"

namespace placedb::storage {

class StorageError : public Error {
 public:
  StorageError(ErrorCode code, const std::string& message, int sqlite_code = 0,
               std::string sqlite_message = {}, std::string sql = {})
      : Error(code, message),
        sqlite_code_(sqlite_code),
        sqlite_message_(std::move(sqlite_message)),
        sql_(std::move(sql)) {}

  // The primary or extended SQLite result code; 0 when the error did not come from SQLite.
  int sqliteCode() const noexcept { return sqlite_code_; }
  const std::string& sqliteMessage() const noexcept { return sqlite_message_; }
  // The statement that failed; empty for errors outside a statement (open, checks).
  const std::string& sql() const noexcept { return sql_; }

 private:
  int sqlite_code_;
  std::string sqlite_message_;
  std::string sql_;
};

// Which placedb::ErrorCode a SQLite result code stands for (busy -> kMapBusy, full -> kDiskFull,
// readonly -> kReadOnly, notadb/corrupt -> kMapRefused, cantopen -> kIo, else kStorage).
ErrorCode errorCodeForSqlite(int sqlite_code) noexcept;

}  // namespace placedb::storage
