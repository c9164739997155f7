// PgConnection's pipeline: the writes of a transaction are sent without waiting for their
// results, which are read together when the connection next needs an answer (a read, the
// commit). A frame's dozens of writes then cost a few round trips instead of one each.
#include "postgres/pg_connection.h"

namespace placedb::storage::detail {

const std::string& PgConnection::prepare(const char* sql, const PgParams& params) {
  auto found = prepared_.find(sql);
  if (found != prepared_.end()) return found->second;
  const std::string name = "placedb_" + std::to_string(prepared_.size());
  if (PQpipelineStatus(conn_) == PQ_PIPELINE_ON) {
    if (!PQsendPrepare(conn_, name.c_str(), sql, params.size(), params.types().data()))
      fail(nullptr, sql, "cannot send statement");
    sent_.push_back({sql, true});
  } else {
    check(PQprepare(conn_, name.c_str(), sql, params.size(), params.types().data()), sql,
          "cannot prepare statement");
  }
  return prepared_.emplace(sql, name).first->second;
}

void PgConnection::send(const char* sql, const PgParams& params) {
  if (!writing_) {
    run(sql, params);
    return;
  }
  if (PQpipelineStatus(conn_) == PQ_PIPELINE_OFF && !PQenterPipelineMode(conn_))
    fail(nullptr, sql, "cannot enter pipeline mode");
  const std::string& name = prepare(sql, params);
  const auto values = params.values();
  const auto lengths = params.lengths();
  const std::vector<int> formats(params.size(), 1);
  // libpq copies the parameters into its output buffer here: `params` may go.
  if (!PQsendQueryPrepared(conn_, name.c_str(), params.size(), values.data(), lengths.data(),
                           formats.data(), 1))
    fail(nullptr, sql, "cannot send statement");
  sent_.push_back({sql, false});
}

bool PgConnection::drain(std::string* state, std::string* message, std::string* sql) noexcept {
  if (!conn_ || PQpipelineStatus(conn_) == PQ_PIPELINE_OFF) return true;
  bool ok = true;
  auto note = [&](PGresult* r, const std::string& statement) {
    if (!ok) return;  // the first failure is the cause; later ones are aborted by it
    ok = false;
    const char* code = r ? PQresultErrorField(r, PG_DIAG_SQLSTATE) : nullptr;
    *state = code ? code : "";
    *message = r && *PQresultErrorMessage(r) ? PQresultErrorMessage(r) : PQerrorMessage(conn_);
    *sql = statement;
  };
  if (!PQpipelineSync(conn_)) note(nullptr, sent_.empty() ? std::string() : sent_.front().sql);
  for (const Sent& s : sent_) {
    PGresult* r = PQgetResult(conn_);
    const ExecStatusType status = r ? PQresultStatus(r) : PGRES_FATAL_ERROR;
    if (status != PGRES_COMMAND_OK && status != PGRES_TUPLES_OK) {
      if (s.prepare) prepared_.erase(s.sql);  // it was never prepared: prepare it again
      if (status != PGRES_PIPELINE_ABORTED) note(r, s.sql);
    }
    PQclear(r);
    if (!r) break;  // the connection is gone: nothing more will come
    while ((r = PQgetResult(conn_)) != nullptr) PQclear(r);  // the end of this statement's
  }
  sent_.clear();
  if (PQstatus(conn_) == CONNECTION_OK) {
    // The sync's own result, then out of pipeline mode.
    for (PGresult* r = PQgetResult(conn_); r; r = PQgetResult(conn_)) {
      const bool sync = PQresultStatus(r) == PGRES_PIPELINE_SYNC;
      PQclear(r);
      if (sync) break;
    }
    PQexitPipelineMode(conn_);
  }
  return ok;
}

void PgConnection::flush() {
  std::string state, message, sql;
  if (!drain(&state, &message, &sql)) fail(state, message, sql, "statement failed");
}

}  // namespace placedb::storage::detail
