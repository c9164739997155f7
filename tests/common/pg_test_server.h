#pragma once
// The PostgreSQL server of the tests (tests/common/pg_fixture.sh, started by ctest's fixture):
// its URI, and a fresh database per test so that tests running side by side never share a map.
#include <gtest/gtest.h>
#include <libpq-fe.h>

#include <cstdlib>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

namespace placedb::testing {

// The server's URI (database "placedb"), or nullopt with `why` set when the tests must skip.
inline std::optional<std::string> pgServerUri(std::string* why) {
  if (const char* given = std::getenv("PLACEDB_TEST_PG_URI"); given && *given) return given;
  const char* file = std::getenv("PLACEDB_TEST_PG_URI_FILE");
  if (!file || !*file) {
    *why =
        "no PostgreSQL server: run through ctest (its fixture starts one) or set "
        "PLACEDB_TEST_PG_URI";
    return std::nullopt;
  }
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);
  if (line.rfind("skip:", 0) == 0) {
    *why = line;
    return std::nullopt;
  }
  if (line.rfind("postgresql://", 0) != 0) {
    // The fixture ran and wrote neither: that is a failure, not a reason to skip.
    ADD_FAILURE() << "the PostgreSQL fixture left no URI in " << file;
    *why = "no server URI";
    return std::nullopt;
  }
  return line;
}

// Runs one statement on the server's own database; fails the test on error.
inline void pgAdmin(const std::string& server_uri, const std::string& sql) {
  PGconn* conn = PQconnectdb(server_uri.c_str());
  ASSERT_EQ(PQstatus(conn), CONNECTION_OK) << PQerrorMessage(conn);
  PGresult* r = PQexec(conn, sql.c_str());
  const auto status = PQresultStatus(r);
  EXPECT_TRUE(status == PGRES_COMMAND_OK || status == PGRES_TUPLES_OK)
      << sql << ": " << PQresultErrorMessage(r);
  PQclear(r);
  PQfinish(conn);
}

// The rows of a query, each as its cells joined by '|'; an error is one row "error SQLSTATE".
inline std::vector<std::string> pgRows(const std::string& uri, const std::string& sql) {
  PGconn* conn = PQconnectdb(uri.c_str());
  PGresult* r = PQexec(conn, sql.c_str());
  std::vector<std::string> rows;
  if (PQresultStatus(r) == PGRES_FATAL_ERROR) {
    const char* state = PQresultErrorField(r, PG_DIAG_SQLSTATE);
    rows.push_back(std::string("error ") + (state ? state : ""));
  }
  for (int i = 0; PQresultStatus(r) == PGRES_TUPLES_OK && i < PQntuples(r); ++i) {
    std::string row;
    for (int c = 0; c < PQnfields(r); ++c) row += (c ? "|" : "") + std::string(PQgetvalue(r, i, c));
    rows.push_back(row);
  }
  PQclear(r);
  PQfinish(conn);
  return rows;
}

// The URI of database `name` on the server, created empty (dropped first when it exists).
inline std::string freshPgDatabase(const std::string& server_uri, const std::string& name) {
  pgAdmin(server_uri, "DROP DATABASE IF EXISTS " + name + " WITH (FORCE)");
  pgAdmin(server_uri, "CREATE DATABASE " + name);
  std::string uri = server_uri;
  const std::string from = "/placedb?";
  uri.replace(uri.find(from), from.size(), "/" + name + "?");
  return uri;
}

// A lower-case name for the running test, usable as a database name.
inline std::string pgTestDatabaseName() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = std::string("t_") + info->test_suite_name() + "_" + info->name();
  for (char& c : name) c = std::isalnum(static_cast<unsigned char>(c)) ? std::tolower(c) : '_';
  return name.substr(0, 60);
}

}  // namespace placedb::testing

// Skips the test when no server is available; otherwise defines `server` (the URI).
#define PLACEDB_REQUIRE_PG_SERVER(server)                            \
  std::string server;                                                \
  do {                                                               \
    std::string why_;                                                \
    auto uri_ = ::placedb::testing::pgServerUri(&why_);              \
    if (!uri_) GTEST_SKIP() << "PostgreSQL tests skipped: " << why_; \
    server = *uri_;                                                  \
  } while (0)
