#include "postgres/pg_connection.h"

#include <cctype>
#include <cstring>

namespace placedb::storage {

namespace {

// libpq decodes %XX in a URI; PGPASSWORD is taken as it is.
std::string percentDecoded(const std::string& text) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '%' && i + 2 < text.size() &&
        std::isxdigit(static_cast<unsigned char>(text[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(text[i + 2]))) {
      out.push_back(static_cast<char>(std::stoi(text.substr(i + 1, 2), nullptr, 16)));
      i += 2;
    } else {
      out.push_back(text[i]);
    }
  }
  return out;
}

}  // namespace

std::string mapPassword(const std::string& uri) {
  if (!isServerMap(uri)) return {};
  const std::size_t query = uri.find('?');
  if (query != std::string::npos) {
    std::size_t start = query + 1;
    while (start < uri.size()) {
      std::size_t end = uri.find('&', start);
      if (end == std::string::npos) end = uri.size();
      if (uri.compare(start, 9, "password=") == 0)
        return percentDecoded(uri.substr(start + 9, end - start - 9));
      start = end + 1;
    }
  }
  const std::size_t authority = uri.find("://") + 3;
  std::size_t end = uri.find_first_of("/?#", authority);
  if (end == std::string::npos) end = uri.size();
  const std::size_t at = uri.rfind('@', end);
  if (at == std::string::npos || at < authority) return {};
  const std::size_t colon = uri.find(':', authority);
  if (colon == std::string::npos || colon > at) return {};
  return percentDecoded(uri.substr(colon + 1, at - colon - 1));
}

std::string mapDisplayName(const std::string& map) {
  if (!isServerMap(map)) return map;
  const std::size_t scheme_end = map.find("://") + 3;
  std::size_t authority_end = map.find_first_of("/?#", scheme_end);
  if (authority_end == std::string::npos) authority_end = map.size();
  std::string out = map.substr(0, scheme_end);
  const std::string authority = map.substr(scheme_end, authority_end - scheme_end);
  const std::size_t at = authority.rfind('@');
  if (at != std::string::npos) {
    std::string user = authority.substr(0, at);
    if (const std::size_t colon = user.find(':'); colon != std::string::npos) user.resize(colon);
    out += user + authority.substr(at);
  } else {
    out += authority;
  }
  // Query parameters: every one but password=..., in order.
  const std::size_t query = map.find('?', authority_end);
  out +=
      map.substr(authority_end, (query == std::string::npos ? map.size() : query) - authority_end);
  if (query == std::string::npos) return out;
  std::string kept;
  std::size_t start = query + 1;
  while (start <= map.size()) {
    std::size_t end = map.find('&', start);
    if (end == std::string::npos) end = map.size();
    const std::string item = map.substr(start, end - start);
    if (!item.empty() && item.rfind("password=", 0) != 0) kept += (kept.empty() ? "" : "&") + item;
    start = end + 1;
  }
  if (!kept.empty()) out += "?" + kept;
  return out;
}

namespace detail {
namespace {

// Type OIDs (pg_type.dat); libpq publishes no header with them for clients.
constexpr Oid kBool = 16, kBytea = 17, kInt8 = 20, kInt2 = 21, kInt4 = 23, kText = 25,
              kFloat4 = 700, kFloat8 = 701, kVarchar = 1043, kName = 19, kBpchar = 1042;
constexpr Oid kBoolArray = 1000, kByteaArray = 1001, kTextArray = 1009, kInt8Array = 1016,
              kFloat8Array = 1022;

void putU32(std::string& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8)
    out.push_back(static_cast<char>((v >> shift) & 0xff));
}

std::string bigEndian64(std::uint64_t v) {
  std::string out(8, '\0');
  for (int i = 0; i < 8; ++i) out[i] = static_cast<char>((v >> (56 - 8 * i)) & 0xff);
  return out;
}

std::uint64_t readBig(const char* data, int length) {
  std::uint64_t v = 0;
  for (int i = 0; i < length; ++i) v = (v << 8) | static_cast<unsigned char>(data[i]);
  return v;
}

std::string int8Bytes(std::int64_t v) { return bigEndian64(static_cast<std::uint64_t>(v)); }

std::string float8Bytes(double v) {
  std::uint64_t bits = 0;
  std::memcpy(&bits, &v, sizeof bits);
  return bigEndian64(bits);
}

std::string firstLine(const char* message) {
  std::string text = message ? message : "";
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  for (char& c : text)
    if (c == '\n') c = ' ';
  return text;
}

}  // namespace

ErrorCode errorCodeForFailure(const std::string& sqlstate, const std::string& message,
                              bool connection_ok) {
  if (!sqlstate.empty()) return errorCodeForSqlState(sqlstate);
  // libpq's wordings of a connection that went (fe-misc.c, fe-exec.c, fe-protocol3.c).
  static const char* const kLost[] = {
      "server closed the connection unexpectedly", "no connection to the server",
      "could not receive data from server", "could not send data to server",
      "connection to server was lost"};
  bool lost = !connection_ok;
  for (const char* phrase : kLost) lost = lost || message.find(phrase) != std::string::npos;
  return lost ? ErrorCode::kServerUnreachable : ErrorCode::kStorage;
}

ErrorCode errorCodeForSqlState(const std::string& state) {
  if (state.rfind("08", 0) == 0 || state == "57P01" || state == "57P02" || state == "57P03")
    return ErrorCode::kServerUnreachable;
  if (state.rfind("28", 0) == 0) return ErrorCode::kAuthRefused;
  if (state == "53100") return ErrorCode::kDiskFull;
  // Read-only transaction, a standby, or a role without the right to write.
  if (state == "25006" || state == "42501") return ErrorCode::kReadOnly;
  if (state == "40001" || state == "40P01" || state == "55P03") return ErrorCode::kMapBusy;
  if (state == "XX001" || state == "XX002") return ErrorCode::kMapRefused;
  if (state == "3D000") return ErrorCode::kIo;
  return ErrorCode::kStorage;
}

// ---- PgParams ----

void PgParams::push(Oid type, std::string bytes, bool null) {
  types_.push_back(type);
  bytes_.push_back(std::move(bytes));
  nulls_.push_back(null);
}

PgParams& PgParams::add(std::int64_t value) {
  push(kInt8, int8Bytes(value));
  return *this;
}
PgParams& PgParams::add(double value) {
  push(kFloat8, float8Bytes(value));
  return *this;
}
PgParams& PgParams::add(const std::string& text) {
  push(kText, text);
  return *this;
}
PgParams& PgParams::add(const std::optional<std::int64_t>& value) {
  push(kInt8, value ? int8Bytes(*value) : std::string(), !value);
  return *this;
}
PgParams& PgParams::add(const std::optional<double>& value) {
  push(kFloat8, value ? float8Bytes(*value) : std::string(), !value);
  return *this;
}
PgParams& PgParams::addText(const std::optional<std::string>& text) {
  push(kText, text.value_or(std::string()), !text);
  return *this;
}
PgParams& PgParams::addBytes(const void* data, std::size_t size) {
  push(kBytea, size ? std::string(static_cast<const char*>(data), size) : std::string());
  return *this;
}

// The binary array format (array_send): dimensions, a has-nulls flag, the element type, the one
// dimension's length and lower bound, then each element as its length (-1: NULL) and bytes.
void PgParams::pushArray(Oid element, std::size_t count, const std::vector<std::string>* items,
                         const std::vector<bool>* nulls) {
  bool any_null = false;
  if (nulls)
    for (bool n : *nulls) any_null = any_null || n;
  std::string out;
  putU32(out, count ? 1 : 0);
  putU32(out, any_null ? 1 : 0);
  putU32(out, element);
  if (count) {
    putU32(out, static_cast<std::uint32_t>(count));
    putU32(out, 1);
  }
  for (std::size_t i = 0; i < count; ++i) {
    if (nulls && (*nulls)[i]) {
      putU32(out, 0xffffffffu);
      continue;
    }
    putU32(out, static_cast<std::uint32_t>((*items)[i].size()));
    out += (*items)[i];
  }
  Oid type = kInt8Array;
  if (element == kFloat8) type = kFloat8Array;
  if (element == kText) type = kTextArray;
  if (element == kBytea) type = kByteaArray;
  if (element == kBool) type = kBoolArray;
  push(type, std::move(out));
}

PgParams& PgParams::addArray(const std::vector<std::int64_t>& values) {
  std::vector<std::string> items;
  items.reserve(values.size());
  for (std::int64_t v : values) items.push_back(int8Bytes(v));
  pushArray(kInt8, items.size(), &items, nullptr);
  return *this;
}
PgParams& PgParams::addArray(const std::vector<std::optional<std::int64_t>>& values) {
  std::vector<std::string> items;
  std::vector<bool> nulls;
  for (const auto& v : values) {
    items.push_back(v ? int8Bytes(*v) : std::string());
    nulls.push_back(!v);
  }
  pushArray(kInt8, items.size(), &items, &nulls);
  return *this;
}
PgParams& PgParams::addArray(const std::vector<double>& values) {
  std::vector<std::string> items;
  items.reserve(values.size());
  for (double v : values) items.push_back(float8Bytes(v));
  pushArray(kFloat8, items.size(), &items, nullptr);
  return *this;
}
PgParams& PgParams::addArray(const std::vector<std::string>& texts) {
  pushArray(kText, texts.size(), &texts, nullptr);
  return *this;
}
PgParams& PgParams::addBytesArray(const std::vector<std::pair<const void*, std::size_t>>& blobs) {
  std::vector<std::string> items;
  items.reserve(blobs.size());
  for (const auto& [data, size] : blobs)
    items.emplace_back(size ? std::string(static_cast<const char*>(data), size) : std::string());
  pushArray(kBytea, items.size(), &items, nullptr);
  return *this;
}

PgParams& PgParams::addCell(const CellValue& v, Oid target) {
  using Kind = CellValue::Kind;
  if (v.kind == Kind::kNull) {
    push(target, std::string(), true);
  } else if (target == kFloat8) {
    push(target, float8Bytes(v.kind == Kind::kInteger ? static_cast<double>(v.integer) : v.real));
  } else if (target == kText || target == kBytea) {
    push(target, v.kind == Kind::kInteger ? std::to_string(v.integer)
                 : v.kind == Kind::kReal  ? std::to_string(v.real)
                                          : v.bytes);
  } else {
    push(kInt8, int8Bytes(v.kind == Kind::kReal ? static_cast<std::int64_t>(v.real) : v.integer));
  }
  return *this;
}

std::vector<const char*> PgParams::values() const {
  std::vector<const char*> out;
  for (std::size_t i = 0; i < bytes_.size(); ++i)
    out.push_back(nulls_[i] ? nullptr : bytes_[i].data());
  return out;
}

std::vector<int> PgParams::lengths() const {
  std::vector<int> out;
  for (const auto& b : bytes_) out.push_back(static_cast<int>(b.size()));
  return out;
}

// ---- PgResult ----

std::int64_t PgResult::changed() const {
  const char* tuples = PQcmdTuples(result_);
  return tuples && *tuples ? std::stoll(tuples) : 0;
}

const char* PgResult::raw(int row, int column, int* length) const {
  *length = PQgetlength(result_, row, column);
  return PQgetvalue(result_, row, column);
}

std::int64_t PgResult::integer(int row, int column) const {
  if (isNull(row, column)) return 0;
  int length = 0;
  const char* data = raw(row, column, &length);
  const Oid type = PQftype(result_, column);
  if (type == kInt8 || type == kInt4 || type == kInt2 || type == kBool) {
    const std::uint64_t raw = readBig(data, length);
    // Sign-extend the narrower types.
    const int bits = length * 8;
    if (bits < 64 && (raw >> (bits - 1)) & 1)
      return static_cast<std::int64_t>(raw | (~0ULL << bits));
    return static_cast<std::int64_t>(raw);
  }
  throw StorageError(ErrorCode::kInternal, "column " + std::to_string(column) + " of type " +
                                               std::to_string(type) + " read as an integer");
}

std::optional<std::int64_t> PgResult::optionalInteger(int row, int column) const {
  if (isNull(row, column)) return std::nullopt;
  return integer(row, column);
}

double PgResult::real(int row, int column) const {
  if (isNull(row, column)) return 0;
  int length = 0;
  const char* data = raw(row, column, &length);
  const Oid type = PQftype(result_, column);
  if (type == kFloat8) {
    const std::uint64_t bits = readBig(data, 8);
    double v = 0;
    std::memcpy(&v, &bits, sizeof v);
    return v;
  }
  if (type == kFloat4) {
    const auto bits = static_cast<std::uint32_t>(readBig(data, 4));
    float v = 0;
    std::memcpy(&v, &bits, sizeof v);
    return v;
  }
  return static_cast<double>(integer(row, column));
}

std::optional<double> PgResult::optionalReal(int row, int column) const {
  if (isNull(row, column)) return std::nullopt;
  return real(row, column);
}

std::string PgResult::text(int row, int column) const {
  if (isNull(row, column)) return {};
  int length = 0;
  const char* data = raw(row, column, &length);
  const Oid type = PQftype(result_, column);
  if (type == kText || type == kVarchar || type == kName || type == kBpchar || type == kBytea)
    return std::string(data, length);
  return std::to_string(integer(row, column));
}

std::pair<const std::uint8_t*, std::size_t> PgResult::bytes(int row, int column) const {
  int length = 0;
  const char* data = raw(row, column, &length);
  return {reinterpret_cast<const std::uint8_t*>(data), static_cast<std::size_t>(length)};
}

CellValue PgResult::cell(int row, int column) const {
  if (isNull(row, column)) return {};
  const Oid type = PQftype(result_, column);
  if (type == kFloat8 || type == kFloat4) return {CellValue::Kind::kReal, 0, real(row, column), {}};
  if (type == kText || type == kVarchar || type == kName || type == kBpchar)
    return {CellValue::Kind::kText, 0, 0, text(row, column)};
  if (type == kBytea) {
    const auto [data, size] = bytes(row, column);
    return {CellValue::Kind::kBlob, 0, 0, std::string(reinterpret_cast<const char*>(data), size)};
  }
  return {CellValue::Kind::kInteger, integer(row, column), 0, {}};
}

// ---- PgConnection ----

std::string PgConnection::scrubbed(std::string text) const {
  for (const std::string& secret : secrets_) {
    if (secret.empty()) continue;
    const std::string shown =
        secret.size() > 8 && secret.find("://") != std::string::npos ? label_ : std::string("***");
    for (std::size_t at = text.find(secret); at != std::string::npos;
         at = text.find(secret, at + shown.size()))
      text.replace(at, secret.size(), shown);
  }
  return text;
}

PgConnection::PgConnection(const std::string& uri, std::string label, int connect_timeout_s)
    : label_(std::move(label)) {
  // libpq may quote the URI in a message about its syntax: neither it nor its password (as
  // written or decoded) may reach one.
  secrets_ = {uri, mapPassword(uri)};
  if (const std::size_t at = uri.find('@'); at != std::string::npos) {
    const std::size_t colon = uri.find(':', uri.find("://") + 3);
    if (colon != std::string::npos && colon < at)
      secrets_.push_back(uri.substr(colon + 1, at - colon - 1));
  }
  // The URI comes last so that its own settings (connect_timeout=, application_name=) win;
  // libpq also reads PGPASSFILE, PGSSLMODE and the other PG* variables for what it leaves out.
  const std::string timeout = std::to_string(connect_timeout_s);
  const char* keys[] = {"connect_timeout", "fallback_application_name", "dbname", nullptr};
  const char* values[] = {timeout.c_str(), "placedb", uri.c_str(), nullptr};
  conn_ = PQconnectdbParams(keys, values, 1);
  if (conn_ && PQstatus(conn_) == CONNECTION_OK) {
    // Notices (an IF EXISTS that found nothing) are not the user's business.
    PQsetNoticeProcessor(
        conn_, [](void*, const char*) {}, nullptr);
    exec("SET client_min_messages = warning");
    return;
  }
  const std::string reason =
      scrubbed(conn_ ? firstLine(PQerrorMessage(conn_)) : std::string("out of memory"));
  ErrorCode code = ErrorCode::kServerUnreachable;
  std::string what = "cannot reach the server";
  // A URI libpq cannot parse never reached a server: that is the caller's argument.
  const bool tried = reason.find("connection to server") != std::string::npos ||
                     reason.find("could not") != std::string::npos ||
                     reason.find("timeout") != std::string::npos;
  // libpq gives no SQLSTATE for a refused connection; its messages and flags tell the cases.
  if (!tried) {
    code = ErrorCode::kInvalidArgument;
    what = "not a valid connection URI";
  } else if (conn_ && (PQconnectionNeedsPassword(conn_) ||
                       reason.find("authentication failed") != std::string::npos ||
                       reason.find("no password supplied") != std::string::npos ||
                       (reason.find("role \"") != std::string::npos &&
                        reason.find("does not exist") != std::string::npos))) {
    code = ErrorCode::kAuthRefused;
    what = "the server refused the credentials";
  } else if (reason.find("database \"") != std::string::npos &&
             reason.find("does not exist") != std::string::npos) {
    code = ErrorCode::kIo;
    what = "no such database (create it first, e.g. with createdb)";
  }
  PQfinish(conn_);
  conn_ = nullptr;
  throw StorageError(code, "map " + label_ + ": " + what + ": " + reason);
}

PgConnection::~PgConnection() { PQfinish(conn_); }

void PgConnection::fail(PGresult* result, const std::string& sql, const std::string& what) {
  const char* state = result ? PQresultErrorField(result, PG_DIAG_SQLSTATE) : nullptr;
  const std::string sqlstate = state ? state : "";
  const std::string message =
      firstLine(result && *PQresultErrorMessage(result) ? PQresultErrorMessage(result)
                                                        : PQerrorMessage(conn_));
  PQclear(result);
  fail(sqlstate, message, sql, what);
}

void PgConnection::fail(const std::string& sqlstate, const std::string& raw_message,
                        const std::string& sql, const std::string& what) {
  const std::string message = scrubbed(firstLine(raw_message.c_str()));
  const ErrorCode code = errorCodeForFailure(sqlstate, message, PQstatus(conn_) == CONNECTION_OK);
  std::string text = what + ": " + message;
  if (!sqlstate.empty()) text += " (SQLSTATE " + sqlstate + ")";
  if (!sql.empty() && sql.size() < 400) text += " in statement: " + sql;
  text += " (map " + label_ + ")";
  throw StorageError(code, text, 0, message, sql);
}

PgResult PgConnection::check(PGresult* result, const std::string& sql, const std::string& what) {
  const ExecStatusType status = result ? PQresultStatus(result) : PGRES_FATAL_ERROR;
  if (status != PGRES_COMMAND_OK && status != PGRES_TUPLES_OK) fail(result, sql, what);
  return PgResult(result);
}

PgResult PgConnection::run(const char* sql, const PgParams& params) {
  flush();
  const std::string& name = prepare(sql, params);
  const auto values = params.values();
  const auto lengths = params.lengths();
  const std::vector<int> formats(params.size(), 1);
  return check(PQexecPrepared(conn_, name.c_str(), params.size(), values.data(), lengths.data(),
                              formats.data(), 1),
               sql, "statement failed");
}

void PgConnection::exec(const std::string& sql) {
  flush();
  check(PQexec(conn_, sql.c_str()), sql.size() < 200 ? sql : std::string(), "on map " + label_);
}

std::int64_t PgConnection::queryInt(const std::string& sql) {
  flush();
  PGresult* result = PQexec(conn_, sql.c_str());
  check(result, sql, "query failed").release();
  const std::int64_t value = PQntuples(result) > 0 && !PQgetisnull(result, 0, 0)
                                 ? std::stoll(PQgetvalue(result, 0, 0))
                                 : 0;
  PQclear(result);
  return value;
}

bool PgConnection::inTransaction() const {
  const PGTransactionStatusType status = PQtransactionStatus(conn_);
  return status == PQTRANS_INTRANS || status == PQTRANS_INERROR || status == PQTRANS_ACTIVE;
}

void PgConnection::beginWrite() {
  exec("BEGIN");
  writing_ = true;
}

void PgConnection::commit() {
  try {
    flush();
  } catch (...) {
    rollbackQuietly();
    throw;
  }
  writing_ = false;
  // COMMIT of a transaction in which a statement failed only rolls back, without an error: the
  // frame must not look committed.
  if (PQtransactionStatus(conn_) == PQTRANS_INERROR) {
    rollbackQuietly();
    throw StorageError(ErrorCode::kStorage,
                       "map " + label_ + ": commit of a transaction in which a statement failed");
  }
  try {
    exec("COMMIT");
  } catch (...) {
    rollbackQuietly();
    throw;
  }
}

void PgConnection::rollback() {
  std::string state, message, sql;
  drain(&state, &message, &sql);  // the transaction ends anyway: its failures do not matter
  writing_ = false;
  if (inTransaction()) exec("ROLLBACK");
}

void PgConnection::rollbackQuietly() noexcept {
  std::string state, message, sql;
  drain(&state, &message, &sql);
  writing_ = false;
  if (conn_ && inTransaction()) PQclear(PQexec(conn_, "ROLLBACK"));
}

// One snapshot for every read until it ends, as SQLite's read transaction gives.
void PgConnection::beginRead() { exec("BEGIN ISOLATION LEVEL REPEATABLE READ READ ONLY"); }

void PgConnection::endReadQuietly() noexcept {
  if (conn_ && inTransaction()) PQclear(PQexec(conn_, "COMMIT"));
}

}  // namespace detail
}  // namespace placedb::storage
