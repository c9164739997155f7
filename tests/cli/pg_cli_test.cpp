// The command line on a map on a PostgreSQL server: the same decisions as on a file (straight
// and resumed), a second writer refused, credentials that never show and their exit codes, and
// placedb copy between backends.
#include <gtest/gtest.h>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "cli_test_support.h"
#include "file_bytes.h"
#include "pg_test_server.h"
#include "placedb/storage/map_store.h"
#include "subprocess.h"

namespace placedb::testing {
namespace {

namespace fs = std::filesystem;

// SCHEMA.md's grants of a robot that maps, run as the section "Roles" gives them (its first sql
// block, the CREATE ROLE left out) for `role` on the map `uri` in database `db`: the tests prove
// the grants the document gives, not a copy of them.
void grantRobot(const std::string& uri, const std::string& db, const std::string& role) {
  std::ifstream in(PLACEDB_SCHEMA_DOC);
  ASSERT_TRUE(in) << PLACEDB_SCHEMA_DOC;
  const std::string doc((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto section = doc.find("\n### Roles\n");
  ASSERT_NE(section, std::string::npos) << "SCHEMA.md has no section Roles";
  const auto open = doc.find("```sql\n", section);
  ASSERT_NE(open, std::string::npos) << "SCHEMA.md's Roles gives no sql block";
  const auto close = doc.find("```", open + 7);
  std::istringstream lines(doc.substr(open + 7, close - open - 7));
  std::string sql, line;
  while (std::getline(lines, line))
    if (line.rfind("--", 0) != 0) sql += line + "\n";
  int grants = 0;
  for (std::size_t at = 0, end; (end = sql.find(';', at)) != std::string::npos; at = end + 1) {
    std::string statement = sql.substr(at, end - at);
    statement.erase(0, statement.find_first_not_of(" \n"));
    if (statement.rfind("CREATE ROLE", 0) == 0) continue;
    ASSERT_EQ(statement.rfind("GRANT ", 0), 0u) << statement;
    const auto replace = [&statement](const std::string& from, const std::string& to) {
      const auto found = statement.find(from);
      if (found != std::string::npos) statement.replace(found, from.size(), to);
    };
    replace(" DATABASE fleet ", " DATABASE " + db + " ");
    ASSERT_NE(statement.find(" TO robot"), std::string::npos) << statement;
    replace(" TO robot", " TO " + role);
    pgAdmin(uri, statement);
    ++grants;
  }
  EXPECT_EQ(grants, 6) << "SCHEMA.md's Roles changed: check the tests that use its grants";
}

// frames [first, first + count) of lip6_outdoor as a list of absolute paths, or "" when absent.
std::string lip6List(const fs::path& dir, const std::string& name, int first, int count) {
  const fs::path data = dataset("lip6_outdoor");
  if (data.empty()) return {};
  std::ifstream in(data / "frames.txt");
  std::ofstream out(dir / name);
  std::string line;
  for (int i = 0; std::getline(in, line) && i < first + count; ++i)
    if (i >= first) out << (data / line).string() << "\n";
  return (dir / name).string();
}

// The log's rows without the columns that are times (every *_ms): what must not differ.
std::vector<std::string> decisions(const fs::path& log) {
  std::ifstream in(log);
  std::string line;
  std::vector<bool> keep;
  std::vector<std::string> rows;
  while (std::getline(in, line)) {
    // Fields may be quoted and hold commas (rejected_reason).
    std::vector<std::string> cells(1);
    bool quoted = false;
    for (char c : line) {
      if (c == '"') quoted = !quoted;
      if (c == ',' && !quoted)
        cells.emplace_back();
      else
        cells.back().push_back(c);
    }
    if (keep.empty())
      for (const auto& name : cells)
        keep.push_back(name.size() < 3 || name.compare(name.size() - 3, 3, "_ms") != 0);
    std::string row;
    for (std::size_t i = 0; i < cells.size(); ++i)
      if (i >= keep.size() || keep[i]) row += cells[i] + ",";
    rows.push_back(row);
  }
  return rows;
}

nlohmann::json infoWithoutFile(const std::string& map, const fs::path& dir) {
  auto r = placedb({"info", "--json", map}, dir);
  EXPECT_EQ(r.exit_code, 0) << describe(r);
  auto info = nlohmann::json::parse(r.out);
  for (const char* key : {"path", "file_bytes", "wal_bytes"}) info.erase(key);
  return info;
}

class PgCli : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string why;
    auto server = pgServerUri(&why);
    if (!server) GTEST_SKIP() << "PostgreSQL tests skipped: " << why;
    server_ = *server;
    dir_ = scratchDir(std::string("PgCli_") +
                      ::testing::UnitTest::GetInstance()->current_test_info()->name());
  }
  std::string database(const std::string& suffix) {
    return freshPgDatabase(server_, pgTestDatabaseName() + suffix);
  }
  std::string server_;
  fs::path dir_;
};

// The acceptance check of issue #24 on 300 frames of lip6_outdoor (the whole sequence is run
// by hand, see the report of branch pg): every log column but the times is equal on a file and
// on a server, straight and when stopped at frame 150 and resumed.
TEST_F(PgCli, Lip6DecidesOnAServerAsOnAFileStraightAndResumed) {
  const std::string list = lip6List(dir_, "lip6_300.txt", 0, 300);
  if (list.empty()) GTEST_SKIP() << "lip6_outdoor absent under " << datasetsDir();
  const std::string file = (dir_ / "map.placedb").string();
  auto on_file = placedb({"map", file, list, "--log", (dir_ / "file.csv").string(), "-q"}, dir_);
  ASSERT_EQ(on_file.exit_code, 0) << describe(on_file);

  const std::string straight = database("_a");
  auto on_server =
      placedb({"map", straight, list, "--log", (dir_ / "server.csv").string(), "-q"}, dir_);
  ASSERT_EQ(on_server.exit_code, 0) << describe(on_server);
  const auto expected = decisions(dir_ / "file.csv");
  ASSERT_EQ(expected.size(), 301u);
  EXPECT_EQ(decisions(dir_ / "server.csv"), expected);

  const std::string resumed = database("_b");
  const std::string log = (dir_ / "resumed.csv").string();
  auto first = placedb({"map", resumed, list, "--log", log, "--stop-after", "150", "-q"}, dir_);
  ASSERT_EQ(first.exit_code, 0) << describe(first);
  auto rest = placedb({"map", resumed, list, "--log", log, "-q"}, dir_);
  ASSERT_EQ(rest.exit_code, 0) << describe(rest);
  EXPECT_EQ(decisions(log), expected);
  EXPECT_EQ(infoWithoutFile(resumed, dir_)["frames"], 300);
}

// A fleet map: while one writer holds a session, a second writer of that session exits 5, a
// writer of a new session begins one of its own (a side session), and readers go on.
TEST_F(PgCli, SecondWriterOfASessionExitsFiveOthersBeginTheirOwn) {
  const std::string list = lip6List(dir_, "lip6_5.txt", 0, 5);
  if (list.empty()) GTEST_SKIP() << "lip6_outdoor absent under " << datasetsDir();
  const std::string uri = database("");
  ASSERT_EQ(placedb({"map", uri, list, "--stop-after", "3", "-q"}, dir_).exit_code, 0);
  {
    // Another writer holds the main line and session 1, as a `placedb map` resuming it would.
    auto writer = storage::openMapStore(uri, storage::OpenMode::kReadWrite);
    writer->claimSession(1);
    auto second = placedb({"map", uri, list, "-q"}, dir_);
    expectCleanError(second, 5, "busy");
    EXPECT_NE(second.err.find("session 1"), std::string::npos) << second.err;
    const std::string other = lip6List(dir_, "lip6_5_10.txt", 5, 5);
    auto own = placedb({"map", uri, other, "-q"}, dir_);
    EXPECT_EQ(own.exit_code, 0) << describe(own);
    auto info = placedb({"info", "--json", uri}, dir_);
    ASSERT_EQ(info.exit_code, 0) << describe(info);
    const auto json = nlohmann::json::parse(info.out);
    EXPECT_EQ(json["frames"], 8);
    EXPECT_EQ(json["sessions"].size(), 2u);
  }
  // The writer is gone with its locks: session 1, the newest over its list, resumes where it
  // stopped.
  auto resumed = placedb({"map", uri, list, "-q"}, dir_);
  EXPECT_EQ(resumed.exit_code, 0) << describe(resumed);
  auto info = placedb({"info", uri}, dir_);
  EXPECT_NE(info.out.find("frames 10"), std::string::npos) << info.out;
}

// A robot killed mid-run, whose map's main line another robot's new session takes before it
// comes back, still resumes its own session: the new session keeps the killed one's memory in
// rows of its own first. Every frame of both lists is in the map once.
TEST_F(PgCli, AKilledRobotResumesAfterAnotherSessionTookTheMainLine) {
  const std::string robot_a = lip6List(dir_, "lip6_a.txt", 0, 60);
  if (robot_a.empty()) GTEST_SKIP() << "lip6_outdoor absent under " << datasetsDir();
  const std::string robot_b = lip6List(dir_, "lip6_b.txt", 400, 10);
  const std::string uri = database("");
  {
    Process mapping({PLACEDB_CLI_BINARY, "map", uri, robot_a, "-q"}, dir_);
    // Killed once it has committed a few frames, wherever it is then.
    for (int waited = 0; waited < 600; ++waited) {
      std::int64_t frames = 0;
      try {
        frames = storage::openMapStore(uri, storage::OpenMode::kReadOnly)->frameCount();
      } catch (const std::exception&) {
        // Not created yet.
      }
      if (frames >= 12) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    mapping.signal(SIGKILL);
    ASSERT_EQ(mapping.wait().exit_code, 128 + SIGKILL);
  }
  auto other = placedb({"map", uri, robot_b, "-q"}, dir_);
  ASSERT_EQ(other.exit_code, 0) << describe(other);
  auto back = placedb({"map", uri, robot_a}, dir_);
  ASSERT_EQ(back.exit_code, 0) << describe(back);
  EXPECT_NE(back.err.find("resuming session 1"), std::string::npos) << back.err;
  auto store = storage::openMapStore(uri, storage::OpenMode::kReadOnly);
  EXPECT_EQ(store->frameCount(1), 60);
  EXPECT_EQ(store->lastFrameIndex(1), 59);
  EXPECT_EQ(store->frameCount(), 70) << "every frame of both robots once";
  EXPECT_EQ(store->sessions().size(), 2u);
}

TEST_F(PgCli, CredentialsNeverShowAndRefusalsHaveTheirCodes) {
  const std::string uri = database("");
  pgAdmin(server_, "DROP ROLE IF EXISTS cli_robot");
  pgAdmin(server_, "CREATE ROLE cli_robot LOGIN PASSWORD 'open-sesame'");
  pgAdmin(uri, "GRANT ALL ON SCHEMA public TO cli_robot");
  const std::string host = uri.substr(uri.find("host="), uri.find('&') - uri.find("host="));
  const std::string db = pgTestDatabaseName();
  const std::string good = "postgresql://cli_robot:open-sesame@/" + db + "?" + host;
  const std::string bad = "postgresql://cli_robot:wrong-sesame@/" + db + "?" + host;

  auto refused = placedb({"info", bad}, dir_);
  expectCleanError(refused, 12, "refused the credentials");
  EXPECT_EQ(refused.err.find("wrong-sesame"), std::string::npos) << refused.err;
  EXPECT_EQ(lines(refused.err).size(), 1u) << refused.err;

  auto unreachable =
      placedb({"info", "postgresql://cli_robot:open-sesame@/x?host=/nonexistent"}, dir_);
  expectCleanError(unreachable, 11, "cannot reach the server");
  EXPECT_EQ(unreachable.err.find("open-sesame"), std::string::npos) << unreachable.err;

  // The right password maps, and no output, log or stored row holds it.
  const std::string list = lip6List(dir_, "lip6_5.txt", 0, 5);
  if (list.empty()) GTEST_SKIP() << "lip6_outdoor absent under " << datasetsDir();
  const fs::path log = dir_ / "run.csv";
  auto mapped = placedb({"map", good, list, "--log", log.string()}, dir_);
  ASSERT_EQ(mapped.exit_code, 0) << describe(mapped);
  auto info = placedb({"info", "--json", good}, dir_);
  ASSERT_EQ(info.exit_code, 0) << describe(info);
  for (const auto& text : {mapped.out, mapped.err, info.out, info.err, readBytes(log)})
    EXPECT_EQ(text.find("open-sesame"), std::string::npos) << text;
  EXPECT_NE(info.out.find("postgresql://cli_robot@/" + db), std::string::npos) << info.out;
  // A role that may only read queries the map and is refused writing it (exit 6).
  pgAdmin(server_, "DROP ROLE IF EXISTS cli_reader");
  pgAdmin(server_, "CREATE ROLE cli_reader LOGIN PASSWORD 'read-only-sesame'");
  pgAdmin(uri, "GRANT SELECT ON ALL TABLES IN SCHEMA public TO cli_reader");
  const std::string reader = "postgresql://cli_reader:read-only-sesame@/" + db + "?" + host;
  auto read = placedb({"info", reader}, dir_);
  EXPECT_EQ(read.exit_code, 0) << describe(read);
  EXPECT_NE(read.out.find("frames 5"), std::string::npos) << read.out;
  auto write = placedb({"map", reader, list, "--new-session"}, dir_);
  expectCleanError(write, 6, "permission denied");
  EXPECT_EQ(write.err.find("read-only-sesame"), std::string::npos) << write.err;

  EXPECT_EQ(pgRows(uri,
                   "SELECT count(*) FROM sessions s, settings t WHERE "
                   "s.source || s.software_version || t.value LIKE '%sesame%'"),
            std::vector<std::string>{"0"});
}

// SCHEMA.md's least-privilege robot: with exactly its grants, a robot whose password comes from
// a password file (libpq's PGPASSFILE; the URI holds none) and whose URI asks sslmode=disable
// maps a session of its own and queries; it cannot delete what others stored nor alter tables.
TEST_F(PgCli, LeastPrivilegeRobotMapsAndQueriesWithAPasswordFile) {
  const std::string list = lip6List(dir_, "lip6_8.txt", 0, 8);
  if (list.empty()) GTEST_SKIP() << "lip6_outdoor absent under " << datasetsDir();
  const std::string uri = database("");
  const std::string owner_list = lip6List(dir_, "lip6_4.txt", 0, 4);
  ASSERT_EQ(placedb({"map", uri, owner_list, "-q"}, dir_).exit_code, 0);  // the owner's session

  const std::string db = pgTestDatabaseName();
  pgAdmin(server_, "DROP ROLE IF EXISTS cli_fleet_robot");
  pgAdmin(server_, "CREATE ROLE cli_fleet_robot LOGIN PASSWORD 'pass-file-secret'");
  // The grants as SCHEMA.md gives them.
  ASSERT_NO_FATAL_FAILURE(grantRobot(uri, db, "cli_fleet_robot"));

  const std::string host = uri.substr(uri.find("host="), uri.find('&') - uri.find("host="));
  const fs::path pass_file = dir_ / "pgpass";
  {
    std::ofstream out(pass_file);
    out << "*:*:" << db << ":cli_fleet_robot:pass-file-secret\n";
  }
  fs::permissions(pass_file, fs::perms::owner_read | fs::perms::owner_write);
  ::setenv("PGPASSFILE", pass_file.c_str(), 1);
  ::setenv("PGSSLMODE", "prefer", 1);
  const std::string robot = "postgresql://cli_fleet_robot@/" + db + "?" + host + "&sslmode=disable";

  {
    // The owner writes too (it holds the main line): the robot's session is a side session,
    // whose own memory it rewrites as it maps.
    auto owner = storage::openMapStore(uri, storage::OpenMode::kReadWrite);
    auto mapped = placedb({"map", robot, list, "--new-session", "-q"}, dir_);
    EXPECT_EQ(mapped.exit_code, 0) << describe(mapped);
    EXPECT_EQ(mapped.err.find("pass-file-secret"), std::string::npos) << mapped.err;
    EXPECT_EQ(owner->sessionMemory(2), storage::SessionMemory::kOwn);
  }
  auto query = placedb({"query", robot,
                        dataset("lip6_outdoor").string() + "/images/"
                                                           "outdoor_kennedylong_000006.png"},
                       dir_);
  EXPECT_EQ(query.exit_code, 0) << describe(query);
  auto info = placedb({"info", robot}, dir_);
  EXPECT_EQ(info.exit_code, 0) << describe(info);
  EXPECT_NE(info.out.find("session 2: 8 frames"), std::string::npos) << info.out;
  for (const auto& text : {query.out, query.err, info.out})
    EXPECT_EQ(text.find("pass-file-secret"), std::string::npos) << text;

  // Without the file, the same URI is refused as credentials (exit 12), in one line.
  ::setenv("PGPASSFILE", (dir_ / "no-such-pgpass").c_str(), 1);
  auto refused = placedb({"info", robot}, dir_);
  expectCleanError(refused, 12, "refused the credentials");
  ::unsetenv("PGPASSFILE");
  ::unsetenv("PGSSLMODE");

  // The robot's own connection: others' frames and sessions cannot be deleted, nor the schema
  // changed.
  const std::string robot_with_password =
      "postgresql://cli_fleet_robot:pass-file-secret@/" + db + "?" + host;
  PGconn* conn = PQconnectdb(robot_with_password.c_str());
  ASSERT_EQ(PQstatus(conn), CONNECTION_OK) << PQerrorMessage(conn);
  for (const char* sql : {"DELETE FROM frames", "DELETE FROM sessions WHERE id = 1",
                          "ALTER TABLE frames ADD COLUMN x INTEGER", "DROP TABLE links"}) {
    PGresult* r = PQexec(conn, sql);
    EXPECT_EQ(PQresultStatus(r), PGRES_FATAL_ERROR) << sql;
    EXPECT_STREQ(PQresultErrorField(r, PG_DIAG_SQLSTATE), "42501") << sql;  // no privilege
    PQclear(r);
  }
  PQfinish(conn);
}

// Two robots with SCHEMA.md's grants map a fleet map one after the other (each holds the main line
// while it maps). Then robot B, connected as a tool would be and holding no lock, cannot touch
// A's places, references, keypoints or session, the main line's memory, or the metadata: each
// write is refused with SQLSTATE 42501, also after B is granted every privilege on the tables
// (the map owner's triggers confine it, not only the grants). The fleet is not locked out: the
// owner's info and check still answer, and B can still map its own session.
TEST_F(PgCli, RobotsCannotTouchOtherRobotsPlacesNorLockTheFleetOut) {
  const std::string list_a = lip6List(dir_, "lip6_a.txt", 0, 6);
  if (list_a.empty()) GTEST_SKIP() << "lip6_outdoor absent under " << datasetsDir();
  const std::string list_b = lip6List(dir_, "lip6_b.txt", 300, 6);
  const std::string list_b2 = lip6List(dir_, "lip6_b2.txt", 600, 3);
  const std::string uri = database("");
  ASSERT_EQ(placedb({"map", uri, lip6List(dir_, "lip6_o.txt", 900, 3), "-q"}, dir_).exit_code, 0);
  const std::string db = pgTestDatabaseName();
  const std::string host = uri.substr(uri.find("host="), uri.find('&') - uri.find("host="));
  std::map<std::string, std::string> robot_uri;
  for (const std::string role : {"cli_robot_a", "cli_robot_b"}) {
    pgAdmin(server_, "DROP ROLE IF EXISTS " + role);
    pgAdmin(server_, "CREATE ROLE " + role + " LOGIN PASSWORD 'robot-secret'");
    ASSERT_NO_FATAL_FAILURE(grantRobot(uri, db, role));
    robot_uri[role] = "postgresql://" + role + ":robot-secret@/" + db + "?" + host;
  }
  auto a = placedb({"map", robot_uri["cli_robot_a"], list_a, "-q"}, dir_);
  ASSERT_EQ(a.exit_code, 0) << describe(a);
  auto b = placedb({"map", robot_uri["cli_robot_b"], list_b, "-q"}, dir_);
  ASSERT_EQ(b.exit_code, 0) << describe(b);

  PGconn* conn = PQconnectdb(robot_uri["cli_robot_b"].c_str());
  ASSERT_EQ(PQstatus(conn), CONNECTION_OK) << PQerrorMessage(conn);
  const std::string a_place = "(SELECT min(id) FROM locations WHERE session_id = 2)";
  const std::vector<std::string> attacks = {
      "UPDATE placedb_meta SET value = '99' WHERE key = 'schema_version'",
      "DELETE FROM placedb_meta",
      "DELETE FROM locations",
      "DELETE FROM locations WHERE session_id = 2",
      "UPDATE locations SET weight = weight + 1 WHERE session_id = 2",
      "UPDATE locations SET tier = 2 WHERE session_id = 2",
      "UPDATE locations SET session_id = 3 WHERE session_id = 2",
      "UPDATE locations SET link_count = link_count + 5 WHERE session_id = 2",
      "UPDATE locations SET held = 0 WHERE session_id = 2",
      "INSERT INTO locations (id, session_id, weight, tier, created_frame) "
      "VALUES (999999, 2, 1, 1, 1)",
      "DELETE FROM word_refs WHERE location_id = " + a_place,
      "INSERT INTO word_refs SELECT location_id, 9999, word_id, x, y, size, angle, response "
      "FROM word_refs WHERE location_id = " +
          a_place + " LIMIT 1",
      "UPDATE engine_state SET value = value WHERE key = 'keypoint_descriptors/' || " + a_place,
      "INSERT INTO engine_state (key, value, checksum) VALUES ('latest_view/' || " + a_place +
          ", '\\x00', 0) ON CONFLICT (key) DO UPDATE SET value = excluded.value",
      "UPDATE engine_state SET value = value WHERE key = 'engine.counters'",
      "DELETE FROM engine_state",
      "DELETE FROM filter_posterior",
      "UPDATE filter_posterior_vector SET probabilities = probabilities",
      "DELETE FROM filter_posterior_vector",
      "UPDATE kd_nodes SET split_value = 0",
      "DELETE FROM links",
      "UPDATE links SET score = 0 WHERE location_a IN (SELECT id FROM locations WHERE "
      "session_id = 2) AND location_b IN (SELECT id FROM locations WHERE session_id = 2)",
      "UPDATE place_codes SET code = code WHERE location_id = " + a_place,
      "UPDATE sessions SET source = 'elsewhere' WHERE id = 2",
      "UPDATE sessions SET owner_role = 'cli_robot_b' WHERE id = 2",
      "DELETE FROM sessions WHERE id = 2",
      "DELETE FROM frames WHERE session_id = 2",
      "UPDATE settings SET value = '1' WHERE session_id = 2",
      "INSERT INTO vocabulary_imports (file, checksum, word_count, mode, imported_at) "
      "VALUES ('x', 'y', 0, 'fixed', 'now')",
      "DELETE FROM id_blocks",
      "TRUNCATE placedb_meta",
      "TRUNCATE word_refs",
  };
  const auto expectRefused = [&conn](const std::string& sql, const std::string& when) {
    PGresult* r = PQexec(conn, sql.c_str());
    EXPECT_EQ(PQresultStatus(r), PGRES_FATAL_ERROR) << when << ": " << sql;
    const char* state = PQresultErrorField(r, PG_DIAG_SQLSTATE);
    EXPECT_STREQ(state ? state : "", "42501")
        << when << ": " << sql << ": " << PQresultErrorMessage(r);
    PQclear(r);
  };
  for (const auto& sql : attacks) expectRefused(sql, "with the documented grants");
  pgAdmin(uri, "GRANT ALL ON ALL TABLES IN SCHEMA public TO cli_robot_b");
  for (const auto& sql : attacks) expectRefused(sql, "with every privilege");
  PQfinish(conn);

  // Nothing moved: the owner and every robot still use the map.
  auto info = placedb({"info", uri, "--json"}, dir_);
  ASSERT_EQ(info.exit_code, 0) << describe(info);
  EXPECT_NE(info.out.find("\"schema_version\": " +
                          std::to_string(storage::MapStore::currentSchemaVersion())),
            std::string::npos)
      << info.out;
  auto check = placedb({"check", uri, "-q"}, dir_);
  EXPECT_EQ(check.exit_code, 0) << describe(check);
  auto again = placedb({"map", robot_uri["cli_robot_b"], list_b2, "-q"}, dir_);
  EXPECT_EQ(again.exit_code, 0) << describe(again);
}

// The guards are keyed to the map's owner (migrations/pg/0021): its writes skip them before they
// run. Handed to another owner (REASSIGN OWNED), the map's check names each guard still keyed to
// the former one; the new owner's first `map` keys them again, and the former owner, now a robot
// granted everything, is refused on the new owner's rows as any robot is.
TEST_F(PgCli, GuardsFollowTheMapToItsNextOwner) {
  const std::string list = lip6List(dir_, "lip6_old.txt", 0, 4);
  if (list.empty()) GTEST_SKIP() << "lip6_outdoor absent under " << datasetsDir();
  const std::string uri = database("");
  const std::string db = pgTestDatabaseName();
  const std::string host = uri.substr(uri.find("host="), uri.find('&') - uri.find("host="));
  const auto as = [&](const std::string& role) {
    return "postgresql://" + role + ":owner-secret@/" + db + "?" + host;
  };
  pgAdmin(server_, "DROP ROLE IF EXISTS cli_owner_renamed");
  for (const std::string role : {"cli_owner_old", "cli_owner_new"}) {
    pgAdmin(server_, "DROP ROLE IF EXISTS " + role);
    pgAdmin(server_, "CREATE ROLE " + role + " LOGIN PASSWORD 'owner-secret'");
  }
  pgAdmin(uri, "GRANT ALL ON SCHEMA public TO cli_owner_old, cli_owner_new");
  auto first = placedb({"map", as("cli_owner_old"), list, "-q"}, dir_);
  ASSERT_EQ(first.exit_code, 0) << describe(first);

  pgAdmin(uri, "REASSIGN OWNED BY cli_owner_old TO cli_owner_new");
  ASSERT_NO_FATAL_FAILURE(grantRobot(uri, db, "cli_owner_old"));
  pgAdmin(uri, "GRANT ALL ON ALL TABLES IN SCHEMA public TO cli_owner_old");
  auto stale = placedb({"check", uri}, dir_);
  EXPECT_NE(stale.exit_code, 0) << describe(stale);
  const std::string said = stale.out + stale.err;
  EXPECT_NE(said.find("keyed to another role than the map's owner cli_owner_new"),
            std::string::npos)
      << describe(stale);

  auto second =
      placedb({"map", as("cli_owner_new"), lip6List(dir_, "lip6_new.txt", 300, 4), "-q"}, dir_);
  ASSERT_EQ(second.exit_code, 0) << describe(second);
  auto keyed = placedb({"check", uri, "-q"}, dir_);
  EXPECT_EQ(keyed.exit_code, 0) << describe(keyed);

  PGconn* conn = PQconnectdb(as("cli_owner_old").c_str());
  ASSERT_EQ(PQstatus(conn), CONNECTION_OK) << PQerrorMessage(conn);
  for (const std::string sql :
       {"UPDATE locations SET weight = weight + 1 WHERE session_id = 2",
        "DELETE FROM word_refs WHERE location_id IN (SELECT id FROM locations l WHERE "
        "l.session_id = 2)",
        "UPDATE placedb_meta SET value = '99' WHERE key = 'schema_version'"}) {
    PGresult* r = PQexec(conn, sql.c_str());
    const char* state = PQresultErrorField(r, PG_DIAG_SQLSTATE);
    EXPECT_STREQ(state ? state : "", "42501") << sql << ": " << PQresultErrorMessage(r);
    PQclear(r);
  }
  PQfinish(conn);

  // Renamed, the owner leaves guards keyed to a name no role has: another writer is refused at
  // its open, told what fixes it, until the owner's next `map` keys them again.
  pgAdmin(server_, "ALTER ROLE cli_owner_new RENAME TO cli_owner_renamed");
  const std::string robot_list = lip6List(dir_, "lip6_robot.txt", 600, 3);
  auto refused = placedb({"map", as("cli_owner_old"), robot_list, "-q"}, dir_);
  EXPECT_EQ(refused.exit_code, 4) << describe(refused);
  EXPECT_NE(refused.err.find("keyed to role cli_owner_new, which no longer exists; the map's "
                             "owner cli_owner_renamed keys them again"),
            std::string::npos)
      << describe(refused);
  auto rekeyed = placedb(
      {"map", as("cli_owner_renamed"), lip6List(dir_, "lip6_owner.txt", 700, 3), "-q"}, dir_);
  ASSERT_EQ(rekeyed.exit_code, 0) << describe(rekeyed);
  auto robot = placedb({"map", as("cli_owner_old"), robot_list, "-q"}, dir_);
  EXPECT_EQ(robot.exit_code, 0) << describe(robot);
}

// File -> server -> file: the same info, and a further session mapped on each copy decides as
// on the original.
TEST_F(PgCli, CopyRoundTripKeepsTheMapAndItsDecisions) {
  const std::string first = lip6List(dir_, "first.txt", 0, 120);
  if (first.empty()) GTEST_SKIP() << "lip6_outdoor absent under " << datasetsDir();
  const std::string second = lip6List(dir_, "second.txt", 120, 80);
  const std::string original = (dir_ / "original.placedb").string();
  ASSERT_EQ(placedb({"map", original, first, "-q"}, dir_).exit_code, 0);
  const std::string server = database("");
  auto up = placedb({"copy", original, server}, dir_);
  ASSERT_EQ(up.exit_code, 0) << describe(up);
  const std::string back = (dir_ / "back.placedb").string();
  auto down = placedb({"copy", server, back}, dir_);
  ASSERT_EQ(down.exit_code, 0) << describe(down);
  const auto info = infoWithoutFile(original, dir_);
  EXPECT_EQ(infoWithoutFile(server, dir_), info);
  EXPECT_EQ(infoWithoutFile(back, dir_), info);

  // Refusals leave the destination as it was.
  const std::string before = readBytes(back);
  expectCleanError(placedb({"copy", original, back}, dir_), 2, "exists");
  EXPECT_EQ(readBytes(back), before);
  expectCleanError(placedb({"copy", original, server}, dir_), 2, "not empty");
  EXPECT_EQ(infoWithoutFile(server, dir_), info);

  std::vector<std::vector<std::string>> logs;
  for (const std::string& map : {original, server, back}) {
    const fs::path log = dir_ / ("more" + std::to_string(logs.size()) + ".csv");
    auto more = placedb({"map", map, second, "--log", log.string(), "-q"}, dir_);
    ASSERT_EQ(more.exit_code, 0) << describe(more);
    logs.push_back(decisions(log));
  }
  ASSERT_EQ(logs[0].size(), 81u);
  EXPECT_EQ(logs[1], logs[0]);
  EXPECT_EQ(logs[2], logs[0]);
}

}  // namespace
}  // namespace placedb::testing
