// What the PostgreSQL backend adds to MapStore's rules: the writer's advisory lock, read-only
// opens, refusing a database that is not a placedb map, the shared schema version and views,
// errors that name the map without its password, and checks of damaged rows. The record
// round trips themselves are records_test.cpp's, run on both backends.
#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "pg_test_server.h"
#include "placedb/storage/map_check.h"
#include "placedb/storage/map_store.h"
#include "placedb/storage/migrations.h"
#include "storage_test_util.h"

namespace placedb::storage {
namespace {

using placedb::testing::freshPgDatabase;
using placedb::testing::pgAdmin;
using placedb::testing::pgRows;
using placedb::testing::pgTestDatabaseName;

ErrorCode codeOf(const std::function<void()>& action, std::string* message = nullptr) {
  try {
    action();
  } catch (const Error& e) {
    if (message) *message = e.what();
    return e.code();
  }
  ADD_FAILURE() << "no error";
  return ErrorCode::kInternal;
}

TEST(MapDisplayName, DropsThePasswordAndNothingElse) {
  EXPECT_EQ(mapDisplayName("run.placedb"), "run.placedb");
  EXPECT_EQ(mapDisplayName("postgresql://robot:s3cret@db.example:5432/fleet?sslmode=require"),
            "postgresql://robot@db.example:5432/fleet?sslmode=require");
  EXPECT_EQ(mapDisplayName("postgres://robot@h/fleet"), "postgres://robot@h/fleet");
  EXPECT_EQ(mapDisplayName("postgresql:///fleet?host=/tmp/pg&password=s3cret&user=robot"),
            "postgresql:///fleet?host=/tmp/pg&user=robot");
  EXPECT_EQ(mapDisplayName("postgresql://:s3cret@h/fleet?password=other"), "postgresql://@h/fleet");
  EXPECT_TRUE(isServerMap("postgres://h/db"));
  EXPECT_FALSE(isServerMap("postgresql.placedb"));
  EXPECT_EQ(mapPassword("postgresql://robot:s%40cret@h/db"), "s@cret");
  EXPECT_EQ(mapPassword("postgresql:///db?host=/x&password=p%26q&user=r"), "p&q");
  EXPECT_EQ(mapPassword("postgresql://robot@h/db"), "");
}

// libpq quotes a URI it cannot parse; neither the URI nor its password may reach the message.
TEST(MapDisplayName, AMalformedUriIsAnInvalidArgumentWithoutItsPassword) {
  std::string message;
  EXPECT_EQ(codeOf([&] { openMapStore("postgresql://robot:s3cret@[::1/db", OpenMode::kReadOnly); },
                   &message),
            ErrorCode::kInvalidArgument);
  EXPECT_EQ(message.find("s3cret"), std::string::npos) << message;
  EXPECT_NE(message.find("postgresql://robot@[::1/db"), std::string::npos) << message;
}

TEST(PgMapStore, SecondWriterIsRefusedAsMapBusyReadersAreNot) {
  PLACEDB_REQUIRE_PG_SERVER(server);
  const std::string uri = freshPgDatabase(server, pgTestDatabaseName());
  {
    auto writer = openMapStore(uri, OpenMode::kReadWrite);
    const auto session = writer->beginSession("src", {}, "test");
    testing::writeFrame(*writer, session, 0);
    std::string message;
    EXPECT_EQ(codeOf([&] { openMapStore(uri, OpenMode::kReadWrite); }, &message),
              ErrorCode::kMapBusy);
    EXPECT_NE(message.find("busy"), std::string::npos) << message;
    EXPECT_NE(message.find(uri), std::string::npos) << message;
    auto reader = openMapStore(uri, OpenMode::kReadOnly);
    EXPECT_EQ(reader->frameCount(), 1);
    EXPECT_EQ(codeOf([&] { reader->putState("k", std::string("v")); }), ErrorCode::kReadOnly);
  }
  // The lock went with the writer's connection.
  auto next = openMapStore(uri, OpenMode::kReadWrite);
  EXPECT_EQ(next->frameCount(), 1);
}

TEST(PgMapStore, SchemaVersionAndViewsMatchSqlite) {
  PLACEDB_REQUIRE_PG_SERVER(server);
  const std::string uri = freshPgDatabase(server, pgTestDatabaseName());
  auto store = openMapStore(uri, OpenMode::kReadWrite);
  EXPECT_EQ(store->schemaVersion(), currentSchemaVersion());
  EXPECT_EQ(pgMigrations().back().version, currentSchemaVersion())
      << "a migration was added for SQLite only: add it to migrations/pg/ with the same number";
  const auto session = store->beginSession("src", {{"t_loop", "0.1"}}, "test");
  for (int i = 0; i < 3; ++i) testing::writeFrame(*store, session, i);
  store->insertLink(1, 3, LinkType::kLoopClosure, 0.9);
  // Every view of the SQLite schema answers on the server.
  for (const char* view : {"v_frames", "v_locations", "v_location_frames", "v_location_words",
                           "v_links", "v_loop_closures", "v_hypotheses", "v_loop_closure_poses",
                           "v_vocabulary_growth", "v_kd_trees"})
    pgAdmin(uri, std::string("SELECT * FROM ") + view);
  EXPECT_EQ(pgRows(uri, "SELECT first_frame_a, first_frame_b FROM v_loop_closures"),
            std::vector<std::string>{"0|2"});
}

TEST(PgMapStore, ReadOnlyOpenOfAnEmptyDatabaseFindsNoMapAndWritesNothing) {
  PLACEDB_REQUIRE_PG_SERVER(server);
  const std::string uri = freshPgDatabase(server, pgTestDatabaseName());
  std::string message;
  EXPECT_EQ(codeOf([&] { openMapStore(uri, OpenMode::kReadOnly); }, &message), ErrorCode::kIo);
  EXPECT_NE(message.find("not found"), std::string::npos) << message;
  // Still empty: a read-write open would have created placedb_meta.
  auto store = openMapStore(uri, OpenMode::kReadWrite);
  EXPECT_EQ(store->frameCount(), 0);
}

TEST(PgMapStore, DatabaseOfAnotherProgramIsRefusedUntouched) {
  PLACEDB_REQUIRE_PG_SERVER(server);
  const std::string uri = freshPgDatabase(server, pgTestDatabaseName());
  pgAdmin(uri, "CREATE TABLE invoices (id bigint PRIMARY KEY)");
  std::string message;
  EXPECT_EQ(codeOf([&] { openMapStore(uri, OpenMode::kReadWrite); }, &message),
            ErrorCode::kMapRefused);
  EXPECT_NE(message.find("not a placedb map"), std::string::npos) << message;
  EXPECT_EQ(pgRows(uri, "SELECT count(*) FROM pg_tables WHERE schemaname = 'public'"),
            std::vector<std::string>{"1"});
}

TEST(PgMapStore, NewerSchemaIsRefused) {
  PLACEDB_REQUIRE_PG_SERVER(server);
  const std::string uri = freshPgDatabase(server, pgTestDatabaseName());
  { openMapStore(uri, OpenMode::kReadWrite); }
  pgAdmin(uri, "UPDATE placedb_meta SET value = '99' WHERE key = 'schema_version'");
  for (OpenMode mode : {OpenMode::kReadWrite, OpenMode::kReadOnly}) {
    std::string message;
    EXPECT_EQ(codeOf([&] { openMapStore(uri, mode); }, &message), ErrorCode::kMapRefused);
    EXPECT_NE(message.find("99"), std::string::npos) << message;
  }
}

TEST(PgMapStore, WrongPasswordAndUnreachableServerHaveTheirOwnCodesAndHideThePassword) {
  PLACEDB_REQUIRE_PG_SERVER(server);
  const std::string uri = freshPgDatabase(server, pgTestDatabaseName());
  pgAdmin(server, "DROP ROLE IF EXISTS storage_robot");
  pgAdmin(server, "CREATE ROLE storage_robot LOGIN PASSWORD 'right-horse'");
  const std::string host = uri.substr(uri.find("host="), uri.find('&') - uri.find("host="));
  const std::string db = pgTestDatabaseName();
  std::string message;
  const std::string wrong = "postgresql://storage_robot:wrong-horse@/" + db + "?" + host;
  EXPECT_EQ(codeOf([&] { openMapStore(wrong, OpenMode::kReadOnly); }, &message),
            ErrorCode::kAuthRefused);
  EXPECT_EQ(message.find("wrong-horse"), std::string::npos) << message;
  EXPECT_NE(message.find("postgresql://storage_robot@/" + db), std::string::npos) << message;
  const std::string in_query =
      "postgresql:///" + db + "?" + host + "&user=storage_robot&password=wrong-horse";
  EXPECT_EQ(codeOf([&] { openMapStore(in_query, OpenMode::kReadWrite); }, &message),
            ErrorCode::kAuthRefused);
  EXPECT_EQ(message.find("wrong-horse"), std::string::npos) << message;
  const std::string nowhere = "postgresql://robot:right-horse@/" + db + "?host=/nonexistent-dir";
  EXPECT_EQ(codeOf([&] { openMapStore(nowhere, OpenMode::kReadOnly); }, &message),
            ErrorCode::kServerUnreachable);
  EXPECT_EQ(message.find("right-horse"), std::string::npos) << message;
}

TEST(PgMapStore, DamagedRowsAreRefusedOnReadAndListedByCheck) {
  PLACEDB_REQUIRE_PG_SERVER(server);
  const std::string uri = freshPgDatabase(server, pgTestDatabaseName());
  {
    auto store = openMapStore(uri, OpenMode::kReadWrite);
    const auto session = store->beginSession("src", {}, "test");
    for (int i = 0; i < 3; ++i) testing::writeFrame(*store, session, i);
    store->writeKdNodes({{0, 0, 1, 2, 3, 0.5}}, {}, true);
    EXPECT_EQ(store->loadKdNodes().size(), 1u);
    LocationWordDescriptors words;
    words.location_id = 2;
    words.dim = 8;
    words.word_ids = {5};
    words.created_frames = {2};
    words.descriptors.assign(8, 5.f);
    store->putLocationWordDescriptors(words);
  }
  EXPECT_TRUE(checkMap(uri).ok());
  // A flipped byte inside a descriptor: the server's own checks cannot see it.
  pgAdmin(uri,
          "UPDATE words SET descriptor = set_byte(descriptor, 0, get_byte(descriptor, 0) # 1) "
          "WHERE id = 5");
  pgAdmin(uri, "DELETE FROM kd_nodes");
  pgAdmin(uri,
          "UPDATE location_word_descriptors SET words = set_byte(words, 20, get_byte(words, 20) # "
          "1) WHERE location_id = 2");
  auto store = openMapStore(uri, OpenMode::kReadOnly);
  std::string message;
  EXPECT_EQ(codeOf([&] { store->loadWords({5}); }, &message), ErrorCode::kMapRefused);
  EXPECT_NE(message.find("words row 5"), std::string::npos) << message;
  EXPECT_EQ(codeOf([&] { store->loadKdNodes(); }), ErrorCode::kMapRefused);
  EXPECT_EQ(codeOf([&] { store->locationWordDescriptors({2}); }, &message), ErrorCode::kMapRefused);
  EXPECT_NE(message.find("location_word_descriptors row 2"), std::string::npos) << message;
  const CheckReport report = checkMap(uri);
  ASSERT_EQ(report.findings_total, 3);
  EXPECT_EQ(report.findings[0].table, "words");
  EXPECT_EQ(report.findings[0].row, "5");
  EXPECT_EQ(report.findings[1].table, "location_word_descriptors");
  EXPECT_EQ(report.findings[1].row, "2");
  EXPECT_EQ(report.findings[2].table, "kd_nodes");
}

// Schema 18 keeps a writer's posterior as one row of arrays behind views with the old tables'
// columns (migrations/pg/0018 says why). A map written at 17 keeps every row; a role granted the
// old tables keeps its privileges on the views and on the tables behind them; SQL through the
// views changes the arrays with the old keys; and the store's posterior is what the view shows.
TEST(PgMapStore, SchemaEighteenKeepsThePosteriorRowsTheirKeysAndGrants) {
  PLACEDB_REQUIRE_PG_SERVER(server);
  const std::string uri = freshPgDatabase(server, pgTestDatabaseName());
  for (const Migration& m : pgMigrations())
    if (m.version <= 17) pgAdmin(uri, m.sql);
  pgAdmin(uri,
          "INSERT INTO placedb_meta (key, value) VALUES ('schema_version', '17'), "
          "('application_id', '1347175490')");
  pgAdmin(uri,
          "INSERT INTO sessions (id, started_at, software_version, source) VALUES (1, 't', 'v', "
          "'a'), (2, 't', 'v', 'b')");
  pgAdmin(uri, "INSERT INTO filter_posterior VALUES (7, 0.25, 11), (3, 0.75, 12)");
  pgAdmin(uri, "INSERT INTO session_posterior VALUES (2, 5, 1), (2, 4, 0)");
  pgAdmin(uri,
          "DO $$ BEGIN CREATE ROLE placedb_posterior_robot; EXCEPTION WHEN duplicate_object "
          "THEN NULL; END $$");
  pgAdmin(uri, "GRANT SELECT, INSERT, UPDATE ON filter_posterior TO placedb_posterior_robot");
  openMapStore(uri, OpenMode::kReadWrite);  // migrates
  const std::string rows = "SELECT * FROM filter_posterior ORDER BY location_id";
  EXPECT_EQ(pgRows(uri, rows), (std::vector<std::string>{"3|0.75|12", "7|0.25|11"}));
  EXPECT_EQ(pgRows(uri, "SELECT * FROM session_posterior ORDER BY location_id"),
            (std::vector<std::string>{"2|4|0", "2|5|1"}));
  for (const char* relation : {"filter_posterior", "filter_posterior_vector"})
    EXPECT_EQ(pgRows(uri, std::string("SELECT has_table_privilege('placedb_posterior_robot', '") +
                              relation +
                              "', 'UPDATE'), has_table_privilege("
                              "'placedb_posterior_robot', '" +
                              relation + "', 'DELETE')"),
              std::vector<std::string>{"t|f"})
        << relation;

  EXPECT_EQ(pgRows(uri, "INSERT INTO filter_posterior VALUES (7, 0.5, 1)"),
            std::vector<std::string>{"error 23505"});
  EXPECT_EQ(pgRows(uri, "INSERT INTO filter_posterior VALUES (8, NULL, 1)"),
            std::vector<std::string>{"error 23502"});
  pgAdmin(uri, "INSERT INTO filter_posterior VALUES (9, 0.5, 13)");
  pgAdmin(uri, "UPDATE filter_posterior SET probability = 0.125 WHERE location_id = 3");
  pgAdmin(uri, "DELETE FROM filter_posterior WHERE location_id = 7");
  pgAdmin(uri, "INSERT INTO session_posterior VALUES (2, 6, 0.5), (1, 6, 1)");
  EXPECT_EQ(pgRows(uri, rows), (std::vector<std::string>{"3|0.125|12", "9|0.5|13"}));
  EXPECT_EQ(pgRows(uri,
                   "SELECT session_id, cardinality(location_ids) FROM "
                   "session_posterior_vectors ORDER BY 1"),
            (std::vector<std::string>{"1|1", "2|3"}));

  auto store = openMapStore(uri, OpenMode::kReadWrite);
  store->putPosterior({{4, 0.5}, {2, 0.5}});
  EXPECT_EQ(store->loadPosterior(),
            (std::vector<std::pair<std::int64_t, double>>{{2, 0.5}, {4, 0.5}}));
  EXPECT_EQ(pgRows(uri, "SELECT location_id, probability FROM filter_posterior ORDER BY 1"),
            (std::vector<std::string>{"2|0.5", "4|0.5"}));
  // A probability changed in the arrays themselves fails its row's checksum, as a row did.
  pgAdmin(uri, "UPDATE filter_posterior_vector SET probabilities[1] = 0.25");
  std::string message;
  EXPECT_EQ(codeOf([&] { store->loadPosterior(); }, &message), ErrorCode::kMapRefused);
  EXPECT_NE(message.find("filter_posterior row 4"), std::string::npos) << message;
}

// Schema 19 dropped words' key on their creating frame (migrations/pg/0019 says why): check must
// find a word whose frame was deleted. The frame goes with the server's key triggers off, as only
// the owner can (the other keys that name it are not check's to report: the server keeps them).
TEST(PgMapStore, CheckFindsWordsWhoseFrameWasDeleted) {
  PLACEDB_REQUIRE_PG_SERVER(server);
  const std::string uri = freshPgDatabase(server, pgTestDatabaseName());
  {
    auto store = openMapStore(uri, OpenMode::kReadWrite);
    const auto session = store->beginSession("src", {}, "test");
    for (int i = 0; i < 2; ++i) testing::writeFrame(*store, session, i);
  }
  EXPECT_TRUE(checkMap(uri).ok());
  EXPECT_EQ(pgRows(uri,
                   "SELECT count(*) FROM pg_constraint WHERE conrelid = 'words'::regclass "
                   "AND contype = 'f' AND conkey = ARRAY[(SELECT attnum FROM pg_attribute "
                   "WHERE attrelid = 'words'::regclass AND attname = 'created_frame')]"),
            std::vector<std::string>{"0"});
  pgAdmin(uri, "SET session_replication_role = replica; DELETE FROM frames WHERE id = 2");
  const CheckReport report = checkMap(uri);
  std::vector<std::string> words;
  for (const auto& f : report.findings)
    if (f.table == "words") words.push_back(f.row + ": " + f.problem);
  EXPECT_EQ(words, (std::vector<std::string>{"5: names created frame 2, which is missing",
                                             "6: names created frame 2, which is missing",
                                             "7: names created frame 2, which is missing",
                                             "8: names created frame 2, which is missing"}));
}

// Schema 16 dropped word_refs' keys on its word and location (migrations/pg/0016 says why): the
// server no longer refuses deleting a referenced word or location, so check must find the
// references left dangling; and the store deletes a location's references with it.
TEST(PgMapStore, CheckFindsReferencesWhoseWordOrLocationWasDeleted) {
  PLACEDB_REQUIRE_PG_SERVER(server);
  const std::string uri = freshPgDatabase(server, pgTestDatabaseName());
  {
    auto store = openMapStore(uri, OpenMode::kReadWrite);
    const auto session = store->beginSession("src", {}, "test");
    for (int i = 0; i < 2; ++i) testing::writeFrame(*store, session, i);
  }
  {
    auto store = openMapStore(uri, OpenMode::kReadWrite);
    store->deleteLocation(1);
    EXPECT_TRUE(store->loadWordRefs(1).empty());
  }
  EXPECT_TRUE(checkMap(uri).ok());
  pgAdmin(uri, "DELETE FROM words WHERE id = 6");  // location 2's second reference
  pgAdmin(uri, "INSERT INTO word_refs VALUES (9, 0, 5, 0, 0, 1, 0, 1)");  // no location 9
  const CheckReport report = checkMap(uri);
  ASSERT_EQ(report.findings_total, 2);
  EXPECT_EQ(report.findings[0].table, "word_refs");
  EXPECT_EQ(report.findings[0].row, "2 1");
  EXPECT_NE(report.findings[0].problem.find("word 6"), std::string::npos)
      << report.findings[0].problem;
  EXPECT_EQ(report.findings[1].row, "9 0");
  EXPECT_NE(report.findings[1].problem.find("location 9"), std::string::npos)
      << report.findings[1].problem;
}

}  // namespace
}  // namespace placedb::storage
