// Which exit a failed statement on a server maps to: a lost server (wait for it, resume) against
// a storage error (exit 9). A failure without a SQLSTATE is libpq's own; when it says the
// connection went while a statement ran, the run waits for the server even if the connection's
// status has not followed yet (pipeline mode), as fleet_scenario_test's server restart needs.
#include <gtest/gtest.h>

#include "placedb/error.h"
#include "postgres/pg_connection.h"

namespace placedb::storage::detail {
namespace {

TEST(PgErrorCodes, ALostConnectionIsTheServerWhateverTheStatusSays) {
  const std::string closed =
      "server closed the connection unexpectedly\tThis probably means the server terminated "
      "abnormally\tbefore or while processing the request.";
  EXPECT_EQ(errorCodeForFailure("", closed, true), ErrorCode::kServerUnreachable);
  EXPECT_EQ(errorCodeForFailure("", "no connection to the server", true),
            ErrorCode::kServerUnreachable);
  EXPECT_EQ(errorCodeForFailure("", "anything", false), ErrorCode::kServerUnreachable);
}

TEST(PgErrorCodes, TheServersOwnAnswersKeepTheirSqlState) {
  EXPECT_EQ(errorCodeForFailure("57P01", "terminating connection", true),
            ErrorCode::kServerUnreachable);
  EXPECT_EQ(errorCodeForFailure("42501", "permission denied", true), ErrorCode::kReadOnly);
  EXPECT_EQ(errorCodeForFailure("23505", "server closed the connection unexpectedly", true),
            ErrorCode::kStorage);
  EXPECT_EQ(errorCodeForFailure("", "out of memory", true), ErrorCode::kStorage);
}

}  // namespace
}  // namespace placedb::storage::detail
