// Opening, migrating and refusing map files.
#include <sqlite3.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <regex>
#include <set>
#include <sstream>

#include <gtest/gtest.h>

#include "placedb/storage/migrations.h"
#include "placedb/storage/sqlite_map_store.h"
#include "storage_test_util.h"
#include "test_paths.h"

namespace placedb::storage {
namespace {

using testing::readBytes;
using testing::writeBytes;

using testing::RawDb;

// sqlite_master text without comments and layout, so equal schemas compare equal.
std::string normaliseSql(const std::string& sql) {
  std::string text = std::regex_replace(sql, std::regex("--[^\n]*"), " ");
  text = std::regex_replace(text, std::regex("\\s+"), " ");
  text = std::regex_replace(text, std::regex(" ?([(),;]) ?"), "$1");
  return std::regex_replace(text, std::regex("^ | $"), "");
}

std::vector<std::string> normalisedSchema(const std::string& path) {
  RawDb db(path);
  std::vector<std::string> schema;
  for (const std::string& row :
       db.rows("SELECT type || ' ' || name || ' ' || tbl_name || ' ' || coalesce(sql, '') "
               "FROM sqlite_master ORDER BY type, name")) {
    schema.push_back(normaliseSql(row));
  }
  schema.push_back("application_id " + db.rows("PRAGMA application_id").at(0));
  schema.push_back("user_version " + db.rows("PRAGMA user_version").at(0));
  return schema;
}

void expectRefused(const std::string& path, OpenMode mode, const std::string& reason_part) {
  try {
    SqliteMapStore store(path, mode);
    ADD_FAILURE() << path << " was opened but should have been refused";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), ErrorCode::kMapRefused) << error.what();
    EXPECT_NE(std::string(error.what()).find(reason_part), std::string::npos)
        << "message \"" << error.what() << "\" lacks \"" << reason_part << "\"";
  }
}

// Refused in both modes, with the file byte-identical and no companion files left behind.
void expectRefusedUntouched(const std::string& path, const std::string& reason_part) {
  const std::string before = readBytes(path);
  expectRefused(path, OpenMode::kReadWrite, reason_part);
  expectRefused(path, OpenMode::kReadOnly, reason_part);
  EXPECT_EQ(readBytes(path), before) << path << " changed";
  EXPECT_FALSE(std::filesystem::exists(path + "-wal"));
  EXPECT_FALSE(std::filesystem::exists(path + "-lock"));
}

TEST(Migrations, EmbeddedScriptsAreNumberedWithoutGaps) {
  ASSERT_FALSE(migrations().empty());
  for (std::size_t i = 0; i < migrations().size(); ++i) {
    EXPECT_EQ(migrations()[i].version, static_cast<int>(i + 1));
    std::string prefix = std::to_string(i + 1) + "_";
    prefix.insert(0, 5 - prefix.size(), '0');
    EXPECT_EQ(std::string(migrations()[i].name).rfind(prefix, 0), 0u) << migrations()[i].name;
  }
  EXPECT_EQ(currentSchemaVersion(), migrations().back().version);
  EXPECT_EQ(MapStore::currentSchemaVersion(), currentSchemaVersion());
}

TEST(Migrations, AllMigrationsEqualSchemaSql) {
  const auto dir = placedb::testing::scratchDir("AllMigrationsEqualSchemaSql");
  const std::string migrated = (dir / "migrated.db").string();
  buildMapAtVersion(migrated, currentSchemaVersion());
  const std::string from_file = (dir / "schema.db").string();
  {
    RawDb db(from_file);
    db.exec(readBytes(PLACEDB_SCHEMA_SQL));
  }
  const auto expected = normalisedSchema(from_file);
  ASSERT_GT(expected.size(), 10u);
  EXPECT_EQ(normalisedSchema(migrated), expected);
}

// A frame's rows are written parent last (storage/src/sqlite/sqlite_map_store.cpp,
// MapImpl::commit), so each deferred foreign key is violated until its parent's insert, and at that
// insert SQLite looks up the child rows naming the new parent. Without an index on the child column
// that look is a scan of the whole child table, every frame: the map's cost would grow with its
// size.
TEST(Migrations, EveryDeferredForeignKeyLeadsAnIndex) {
  const auto dir = placedb::testing::scratchDir("EveryDeferredForeignKeyLeadsAnIndex");
  const std::string path = (dir / "map.db").string();
  buildMapAtVersion(path, currentSchemaVersion());
  RawDb db(path);
  int deferred = 0;
  for (const std::string& table : db.rows("SELECT name FROM sqlite_master WHERE type = 'table'")) {
    const std::string sql =
        db.rows("SELECT sql FROM sqlite_master WHERE type = 'table' AND name = '" + table + "'")
            .at(0);
    std::set<std::string> leading;  // first column of each index, and an INTEGER PRIMARY KEY
    for (const std::string& index : db.rows("SELECT name FROM pragma_index_list('" + table + "')"))
      leading.insert(
          db.rows("SELECT name FROM pragma_index_info('" + index + "') WHERE seqno = 0").at(0));
    for (const std::string& pk : db.rows("SELECT name FROM pragma_table_info('" + table +
                                         "') WHERE pk = 1 AND type = 'INTEGER'"))
      leading.insert(pk);
    for (const std::string& column :
         db.rows("SELECT \"from\" FROM pragma_foreign_key_list('" + table + "')")) {
      // The column's own line of the CREATE TABLE says whether its key is deferred.
      const std::size_t at = sql.find("\n  " + column + " ");
      ASSERT_NE(at, std::string::npos) << table << "." << column;
      const std::string line = sql.substr(at + 1, sql.find('\n', at + 1) - at - 1);
      if (line.find("DEFERRABLE INITIALLY DEFERRED") == std::string::npos) continue;
      ++deferred;
      EXPECT_TRUE(leading.count(column)) << table << "." << column << " is deferred, unindexed";
    }
  }
  EXPECT_GE(deferred, 5);
}

TEST(Migrations, NewMapGetsCurrentVersionAndMark) {
  const auto dir = placedb::testing::scratchDir("NewMapGetsCurrentVersionAndMark");
  const std::string missing = (dir / "new.db").string();
  const std::string empty = (dir / "empty.db").string();
  writeBytes(empty, "");
  for (const std::string& path : {missing, empty}) {
    {
      SqliteMapStore store(path, OpenMode::kReadWrite);
      EXPECT_EQ(store.schemaVersion(), currentSchemaVersion());
      EXPECT_FALSE(store.readOnly());
    }
    RawDb db(path);
    EXPECT_EQ(db.rows("PRAGMA application_id").at(0), std::to_string(kApplicationId));
    EXPECT_EQ(db.rows("PRAGMA journal_mode").at(0), "wal");
  }
}

TEST(Migrations, UpgradesFromEveryOlderVersionToCurrent) {
  const auto dir = placedb::testing::scratchDir("UpgradesFromEveryOlderVersion");
  const std::string reference = (dir / "reference.db").string();
  buildMapAtVersion(reference, currentSchemaVersion());
  const auto expected = normalisedSchema(reference);
  // Version 0 is a blank SQLite file; versions 1..current-1 are built from the migrations alone.
  for (int version = 0; version < currentSchemaVersion(); ++version) {
    SCOPED_TRACE("from version " + std::to_string(version));
    const std::string path = (dir / ("v" + std::to_string(version) + ".db")).string();
    if (version == 0) {
      RawDb blank(path);
      blank.exec("PRAGMA user_version = 0");
    } else {
      buildMapAtVersion(path, version);
      RawDb db(path);
      EXPECT_EQ(db.rows("PRAGMA user_version").at(0), std::to_string(version));
    }
    {
      SqliteMapStore store(path, OpenMode::kReadWrite);
      EXPECT_EQ(store.schemaVersion(), currentSchemaVersion());
      const auto session = store.beginSession("src", {}, "test");
      testing::writeFrame(store, session, 0);
      EXPECT_EQ(store.frameCount(), 1);
    }
    auto schema = normalisedSchema(path);
    EXPECT_EQ(schema, expected);
  }
}

TEST(Migrations, BuildMapAtVersionRejectsBadArguments) {
  const auto dir = placedb::testing::scratchDir("BuildMapAtVersionRejects");
  EXPECT_THROW(buildMapAtVersion((dir / "a.db").string(), 0), Error);
  EXPECT_THROW(buildMapAtVersion((dir / "a.db").string(), currentSchemaVersion() + 1), Error);
}

TEST(Refusal, NewerMapNamesBothVersions) {
  const auto dir = placedb::testing::scratchDir("NewerMap");
  const std::string path = (dir / "newer.db").string();
  { SqliteMapStore store(path, OpenMode::kReadWrite); }
  const int newer = currentSchemaVersion() + 1;
  {
    RawDb db(path);
    db.exec("PRAGMA user_version = " + std::to_string(newer));
  }
  std::filesystem::remove(path + "-lock");
  const std::string expected_reason = "schema version " + std::to_string(newer) +
                                      " is newer than this placedb binary supports (schema "
                                      "version " +
                                      std::to_string(currentSchemaVersion()) + ")";
  expectRefusedUntouched(path, expected_reason);
}

TEST(Refusal, ForeignSqliteDatabases) {
  const auto dir = placedb::testing::scratchDir("ForeignSqlite");
  const std::string other_app = (dir / "other_app.db").string();
  {
    RawDb db(other_app);
    db.exec(
        "CREATE TABLE notes (id INTEGER PRIMARY KEY, body TEXT); "
        "INSERT INTO notes (body) VALUES ('hello'); PRAGMA application_id = 42;");
  }
  expectRefusedUntouched(other_app, "not a placedb map (application_id 0x0000002A");

  const std::string plain = (dir / "plain.db").string();
  {
    RawDb db(plain);
    db.exec("CREATE TABLE t (x); INSERT INTO t VALUES (1);");
  }
  expectRefusedUntouched(plain, "not a placedb map");

  // A blank SQLite file has nothing to lose: read-write adopts it, read-only refuses it.
  const std::string blank = (dir / "blank.db").string();
  {
    RawDb db(blank);
    db.exec("PRAGMA user_version = 0");
  }
  expectRefused(blank, OpenMode::kReadOnly, "empty SQLite database");
}

TEST(Refusal, FilesThatAreNotSqlite) {
  const auto dir = placedb::testing::scratchDir("NotSqlite");
  std::mt19937 random(7);
  std::string noise(8192, '\0');
  for (char& c : noise) c = static_cast<char>(random());
  writeBytes((dir / "random.bin").string(), noise);
  writeBytes((dir / "text.db").string(), "frame_index,path\n0,a.png\n1,b.png\n");
  writeBytes((dir / "short.db").string(), "SQLite");
  for (const char* name : {"random.bin", "text.db", "short.db"}) {
    SCOPED_TRACE(name);
    expectRefusedUntouched((dir / name).string(), "not a SQLite database");
  }
  // A header followed by garbage: SQLite itself says it is not a database.
  std::string fake_header = std::string("SQLite format 3") + '\0' + noise.substr(16, 4080);
  fake_header[16] = 0x10;  // page size 4096
  fake_header[17] = 0x00;
  writeBytes((dir / "fake.db").string(), fake_header);
  const std::string before = readBytes((dir / "fake.db").string());
  EXPECT_THROW(SqliteMapStore((dir / "fake.db").string(), OpenMode::kReadWrite), Error);
  EXPECT_EQ(readBytes((dir / "fake.db").string()), before);
}

TEST(Refusal, TruncatedMap) {
  const auto dir = placedb::testing::scratchDir("TruncatedMap");
  const std::string path = (dir / "map.db").string();
  {
    SqliteMapStore store(path, OpenMode::kReadWrite);
    const auto session = store.beginSession("src", {}, "test");
    for (int i = 0; i < 40; ++i) testing::writeFrame(store, session, i, 50);
  }
  std::filesystem::remove(path + "-lock");
  const std::string whole = readBytes(path);
  ASSERT_GT(whole.size(), 16u * 4096);
  const std::string half_pages = (dir / "half.db").string();
  writeBytes(half_pages, whole.substr(0, whole.size() / 2 / 4096 * 4096));
  expectRefusedUntouched(half_pages, "truncated");
  const std::string ragged = (dir / "ragged.db").string();
  writeBytes(ragged, whole.substr(0, whole.size() - 1000));
  expectRefusedUntouched(ragged, "truncated");
}

TEST(Refusal, ReadOnlyOpenOfMissingFileIsIoError) {
  const auto dir = placedb::testing::scratchDir("ReadOnlyMissing");
  try {
    SqliteMapStore store((dir / "absent.db").string(), OpenMode::kReadOnly);
    FAIL() << "opened a missing map read-only";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), ErrorCode::kIo);
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "absent.db"));
}

}  // namespace
}  // namespace placedb::storage

namespace placedb::storage {
namespace {

// Schema 7: a version-6 map's hypotheses keep their rows and gain pose columns, all NULL; new
// rows carry a pose or NULL, and only accepted rows with a pose are closure poses.
TEST(Migrations, SixToSevenAddsNullPoseColumns) {
  const auto dir = placedb::testing::scratchDir("SixToSeven");
  const std::string path = (dir / "v6.db").string();
  buildMapAtVersion(path, 6);
  {
    RawDb db(path);
    db.exec(
        "INSERT INTO sessions (id, started_at, software_version, source) "
        "VALUES (1, '2026-01-01T00:00:00Z', 'old', 'src')");
    db.exec("INSERT INTO frames (id, session_id, source_index, outcome) VALUES (1, 1, 0, 0)");
    db.exec(
        "INSERT INTO hypotheses (frame_id, posterior, loop_probability, accepted) "
        "VALUES (1, 0.5, 0.9, 1)");
  }
  {
    SqliteMapStore store(path, OpenMode::kReadWrite);
    ASSERT_EQ(store.schemaVersion(), MapStore::currentSchemaVersion());
    auto old = store.hypothesis(1);
    ASSERT_TRUE(old);
    EXPECT_TRUE(old->accepted);
    EXPECT_FALSE(old->pose);
    EXPECT_TRUE(store.closurePoses().empty());

    testing::writeFrame(store, 1, 1);  // frame 2 at location 2
    testing::writeFrame(store, 1, 2);  // frame 3 at location 3
    HypothesisRecord with_pose;
    with_pose.frame_id = 3;
    with_pose.best_location_id = 2;
    with_pose.posterior = 0.4;
    with_pose.loop_probability = 0.95;
    with_pose.accepted = true;
    with_pose.pose = ClosurePose{0.9, 0.1, -0.3, 0.2, 0.6, 0.0, 0.8, 21};
    auto tx = store.begin();
    store.insertHypothesis(with_pose);
    tx.commit();
    const auto back = store.hypothesis(3);
    ASSERT_TRUE(back && back->pose);
    EXPECT_EQ(back->pose->qy, -0.3);
    EXPECT_EQ(back->pose->tz, 0.8);
    EXPECT_EQ(back->pose->inliers, 21);
    const auto poses = store.closurePoses();
    ASSERT_EQ(poses.size(), 1u);
    EXPECT_EQ(poses[0].frame_id, 3);
    EXPECT_EQ(poses[0].frame_location_id, 3);
    EXPECT_EQ(poses[0].hypothesis_location_id, 2);
  }
  RawDb db(path);
  EXPECT_EQ(db.rows("SELECT count(*) FROM hypotheses WHERE pose_qw IS NULL AND pose_tx IS NULL "
                    "AND pose_inliers IS NULL"),
            std::vector<std::string>{"1"});
  EXPECT_EQ(db.rows("SELECT frame_id, best_location_id, pose_inliers FROM v_loop_closure_poses"),
            std::vector<std::string>{"3|2|21"});
}

}  // namespace
}  // namespace placedb::storage
