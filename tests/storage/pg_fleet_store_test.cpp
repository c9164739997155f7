// The PostgreSQL backend's part in fleet maps: writers' claims on the main line and on sessions,
// a side session's memory copied from the main line and kept apart from it, id blocks that no
// two writers share and that a rolled-back transaction gives back, and the places of other
// sessions found after a writer's marks. The same rules on a file where they apply.
#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "pg_test_server.h"
#include "placedb/storage/map_check.h"
#include "placedb/storage/map_copy.h"
#include "placedb/storage/map_store.h"
#include "storage_test_util.h"
#include "test_paths.h"

namespace placedb::storage {
namespace {

using placedb::testing::freshPgDatabase;
using placedb::testing::pgTestDatabaseName;

ErrorCode codeOf(const std::function<void()>& action) {
  try {
    action();
  } catch (const Error& e) {
    return e.code();
  }
  ADD_FAILURE() << "no error";
  return ErrorCode::kInternal;
}

std::unique_ptr<MapStore> sideWriter(const std::string& uri) {
  OpenOptions options;
  options.side_writer = true;
  return openMapStore(uri, OpenMode::kReadWrite, options);
}

TEST(PgFleetStore, OneWriterPerSessionAndOneOnTheMainLine) {
  PLACEDB_REQUIRE_PG_SERVER(server);
  const std::string uri = freshPgDatabase(server, pgTestDatabaseName());
  auto main = openMapStore(uri, OpenMode::kReadWrite);
  EXPECT_TRUE(main->sharedByWriters());
  EXPECT_TRUE(main->claimMainLine());
  const auto s1 = main->beginSession("a", {}, "test");
  main->claimSession(s1);
  // Without side_writer a second writer is refused at once, as before fleet maps.
  EXPECT_EQ(codeOf([&] { openMapStore(uri, OpenMode::kReadWrite); }), ErrorCode::kMapBusy);
  auto other = sideWriter(uri);
  EXPECT_FALSE(other->claimMainLine());
  EXPECT_EQ(codeOf([&] { other->claimSession(s1); }), ErrorCode::kMapBusy);
  // Released, the session and then the main line pass to the other writer.
  main->releaseSession(s1);
  other->claimSession(s1);
  main->releaseMainLine();
  EXPECT_TRUE(other->claimMainLine());
  EXPECT_FALSE(main->claimMainLine());
}

TEST(PgFleetStore, SideSessionCopiesTheMainLineAndKeepsItsMemoryApart) {
  PLACEDB_REQUIRE_PG_SERVER(server);
  const std::string uri = freshPgDatabase(server, pgTestDatabaseName());
  auto main = openMapStore(uri, OpenMode::kReadWrite);
  const auto s1 = main->beginSession("a", {}, "test");
  for (int i = 0; i < 3; ++i) testing::writeFrame(*main, s1, i);
  main->setTier({1}, Tier::kLtm);
  main->setTier({2}, Tier::kWm);
  main->setWmAges({{2, 7}, {3, 8}});
  main->putState("engine.counters", std::string("{\"main\":1}"));
  main->putState("map.extractor", std::string("surf-64"));
  main->writeKdNodes({{0, 0, 1, 2, 5, 0.5}}, {}, false);
  main->putPosterior({{-1, 0.25}, {2, 0.75}});

  auto side = sideWriter(uri);
  std::int64_t s2 = 0;
  {
    Transaction tx = side->begin();
    s2 = side->beginSideSession("b", {}, "test");
    tx.commit();
  }
  EXPECT_EQ(side->sessionMemory(s2), SessionMemory::kOwn);
  EXPECT_EQ(side->sessionMemory(s1), SessionMemory::kMainLine);
  // The copy: the main line's writer state, forest, posterior, tiers and ages.
  EXPECT_EQ(side->getStateText("engine.counters"), "{\"main\":1}");
  EXPECT_EQ(side->loadKdNodes().size(), 1u);
  EXPECT_EQ(side->loadPosterior(), main->loadPosterior());
  const auto wm = side->locationsInTier(Tier::kWm);
  ASSERT_EQ(wm.size(), 1u);
  EXPECT_EQ(wm[0].id, 2);
  EXPECT_EQ(side->locationsInTier(Tier::kStm).size(), 1u);
  EXPECT_EQ(side->wmAges().at(2), 7);

  // The side writer's own memory from here on; the main line's and the map-wide keys unchanged.
  side->putState("engine.counters", std::string("{\"side\":1}"));
  side->writeKdNodes({}, {{0, 0}}, false);
  side->putPosterior({{-1, 1.0}});
  side->setTier({2, 3}, Tier::kLtm);
  LocationRecord own{100, s2, 0, Tier::kStm, std::nullopt};
  {
    Transaction tx = side->begin();
    side->insertLocation(own);
    side->setWmAges({{100, 9}});
    tx.commit();
  }
  EXPECT_EQ(main->getStateText("engine.counters"), "{\"main\":1}");
  EXPECT_EQ(side->getStateText("map.extractor"), "surf-64");
  EXPECT_EQ(main->loadKdNodes().size(), 1u);
  EXPECT_TRUE(side->loadKdNodes().empty());
  EXPECT_EQ(main->loadPosterior().size(), 2u);
  EXPECT_EQ(main->locationsInTier(Tier::kWm).size(), 1u);
  EXPECT_EQ(main->location(100)->tier, Tier::kLtm);  // another writer's place: LTM to the main
  const auto side_stm = side->locationsInTier(Tier::kStm);
  ASSERT_EQ(side_stm.size(), 1u);
  EXPECT_EQ(side_stm[0].id, 100);
  EXPECT_EQ(side->wmAges().at(100), 9);
  EXPECT_EQ(side->locationsInTier(Tier::kLtm).size(), 3u);  // 1, 2, 3 in the side's eyes
  main->insertLink(2, 100, LinkType::kLoopClosure, 0.5);
  EXPECT_EQ(side->linkedInTier(100, Tier::kLtm), std::vector<std::int64_t>{2});
  EXPECT_EQ(main->linkedInTier(2, Tier::kLtm), std::vector<std::int64_t>{100});
  // The session the main line's newest is still the newest session without memory of its own.
  EXPECT_EQ(main->sessionMemory(s1), SessionMemory::kMainLine);
}

// Schema 23 dropped the keys of a side session's own memory on its session (migrations/pg/0023
// says why): check must find the rows of a session that was deleted. The session goes with the
// server's key triggers off, as only the owner can (other tables still name it).
TEST(PgFleetStore, CheckFindsSideMemoryWhoseSessionWasDeleted) {
  PLACEDB_REQUIRE_PG_SERVER(server);
  const std::string uri = freshPgDatabase(server, pgTestDatabaseName());
  {
    auto main = openMapStore(uri, OpenMode::kReadWrite);
    const auto s1 = main->beginSession("a", {}, "test");
    for (int i = 0; i < 3; ++i) testing::writeFrame(*main, s1, i);
    main->writeKdNodes({{0, 0, 1, 2, 5, 0.5}}, {}, false);
    auto side = sideWriter(uri);
    Transaction tx = side->begin();
    EXPECT_EQ(side->beginSideSession("b", {}, "test"), 2);
    tx.commit();
  }
  EXPECT_TRUE(checkMap(uri).ok());
  EXPECT_EQ(placedb::testing::pgRows(
                uri,
                "SELECT count(*) FROM pg_constraint WHERE contype = 'f' AND confrelid = "
                "'sessions'::regclass AND conrelid IN ('session_state'::regclass, "
                "'session_kd_nodes'::regclass, 'session_memory'::regclass)"),
            std::vector<std::string>{"0"});
  placedb::testing::pgAdmin(
      uri, "SET session_replication_role = replica; DELETE FROM sessions WHERE id = 2");
  std::vector<std::string> side_tables;
  for (const auto& f : checkMap(uri).findings)
    if (f.table.rfind("session_", 0) == 0) {
      side_tables.push_back(f.table);
      EXPECT_EQ(f.row, "session 2");
      EXPECT_NE(f.problem.find("rows name session 2, which is missing"), std::string::npos)
          << f.problem;
    }
  EXPECT_EQ(side_tables,
            (std::vector<std::string>{"session_kd_nodes", "session_memory", "session_state"}));
}

TEST(PgFleetStore, IdBlocksAreDisjointAndARollbackGivesItsBlockBack) {
  PLACEDB_REQUIRE_PG_SERVER(server);
  const std::string uri = freshPgDatabase(server, pgTestDatabaseName());
  auto one = openMapStore(uri, OpenMode::kReadWrite);
  auto two = sideWriter(uri);
  IdBlock given;
  {
    Transaction tx = one->begin();
    given = one->reserveIds(IdKind::kFrame, 10, 1);
    tx.rollback();
  }
  EXPECT_EQ(given.first, 1);
  Transaction tx = one->begin();
  const IdBlock a = one->reserveIds(IdKind::kFrame, 10, 1);
  EXPECT_EQ(a.first, 1) << "the rolled-back block came back";
  tx.commit();
  const IdBlock b = two->reserveIds(IdKind::kFrame, 10, 1);
  EXPECT_EQ(b.first, 11);
  // A lone writer's next block follows its last one; ids a copy brought are skipped.
  const IdBlock c = one->reserveIds(IdKind::kFrame, 5, a.end);
  EXPECT_EQ(c.first, 21);
  const auto session = one->beginSession("a", {}, "test");
  testing::writeFrame(*one, session, 99);  // frame id 100
  EXPECT_EQ(one->reserveIds(IdKind::kFrame, 5, 1).first, 101);
  EXPECT_EQ(one->reserveIds(IdKind::kWord, 5, 0).first, 401);  // past words 397-400
  EXPECT_EQ(two->reserveIds(IdKind::kWord, 5, 0).first, 406);
}

TEST(PgFleetStore, PlacesOfOtherSessionsAfterTheMarks) {
  PLACEDB_REQUIRE_PG_SERVER(server);
  const std::string uri = freshPgDatabase(server, pgTestDatabaseName());
  auto store = openMapStore(uri, OpenMode::kReadWrite);
  const auto s1 = store->beginSession("a", {}, "test");
  for (int i = 0; i < 3; ++i) testing::writeFrame(*store, s1, i);
  const auto s2 = store->beginSession("b", {}, "test");
  store->putPlaceCode(2, std::vector<std::int8_t>(8, 3));
  auto marks = store->newestLocations();
  EXPECT_EQ(marks.at(s1), 3);
  EXPECT_TRUE(store->placesAfter(s2, marks).empty());
  marks[s1] = 1;
  const auto places = store->placesAfter(s2, marks);
  ASSERT_EQ(places.size(), 2u);
  EXPECT_EQ(places[0].location_id, 2);
  EXPECT_EQ(places[0].session_id, s1);
  EXPECT_EQ(places[0].code, std::vector<std::int8_t>(8, 3));
  EXPECT_TRUE(places[1].code.empty());
  EXPECT_TRUE(store->placesAfter(s1, {}).empty());  // its own are not another's
}

TEST(PgFleetStore, CheckVerifiesTheSideSessionsRows) {
  PLACEDB_REQUIRE_PG_SERVER(server);
  const std::string uri = freshPgDatabase(server, pgTestDatabaseName());
  auto main = openMapStore(uri, OpenMode::kReadWrite);
  const auto s1 = main->beginSession("a", {}, "test");
  testing::writeFrame(*main, s1, 0);
  main->writeKdNodes({{0, 0, 1, 2, 5, 0.5}, {0, 1, 3, 4, 6, 0.25}}, {}, false);
  auto side = sideWriter(uri);
  {
    Transaction tx = side->begin();
    side->beginSideSession("b", {}, "test");
    tx.commit();
  }
  EXPECT_TRUE(checkMap(uri).ok());
  placedb::testing::pgAdmin(uri, "UPDATE session_kd_nodes SET split_value = 0.75 WHERE node = 0");
  placedb::testing::pgAdmin(uri, "DELETE FROM session_kd_nodes WHERE node = 1");
  const CheckReport report = checkMap(uri);
  ASSERT_EQ(report.findings_total, 2);
  EXPECT_EQ(report.findings[0].table, "session_kd_nodes");
  EXPECT_NE(report.findings[0].problem.find("checksum"), std::string::npos);
  EXPECT_NE(report.findings[1].problem.find("holds 1 rows where the map recorded 2"),
            std::string::npos)
      << report.findings[1].problem;
  EXPECT_EQ(report.rows_checked.at("session_kd_nodes"), 1);
}

// Each writer's posterior is one row of arrays on a server (schema 18): a copy to a file takes
// them as rows, and a copy back into another server database makes the arrays again.
TEST(PgFleetStore, ACopyCarriesEveryWritersPosterior) {
  PLACEDB_REQUIRE_PG_SERVER(server);
  const std::string uri = freshPgDatabase(server, pgTestDatabaseName());
  std::int64_t s2 = 0;
  {
    auto main = openMapStore(uri, OpenMode::kReadWrite);
    const auto s1 = main->beginSession("a", {}, "test");
    for (int i = 0; i < 3; ++i) testing::writeFrame(*main, s1, i);
    main->putPosterior({{-1, 0.25}, {2, 0.5}, {3, 0.25}});
    auto side = sideWriter(uri);
    {
      Transaction tx = side->begin();
      s2 = side->beginSideSession("b", {}, "test");
      tx.commit();
    }
    side->putPosterior({{-1, 0.125}, {3, 0.875}});
  }
  const auto dir = placedb::testing::scratchDir("PgFleetStore_ACopyCarriesEveryWritersPosterior");
  const std::string file = (dir / "copy.placedb").string();
  const std::string back = freshPgDatabase(server, pgTestDatabaseName() + "_back");
  {
    auto from = openMapStore(uri, OpenMode::kReadOnly);
    auto to = openMapStore(file, OpenMode::kReadWrite);
    copyMap(*from, *to);
  }
  {
    auto from = openMapStore(file, OpenMode::kReadOnly);
    auto to = openMapStore(back, OpenMode::kReadWrite);
    copyMap(*from, *to);
  }
  for (const std::string& map : {file, back}) {
    auto main = openMapStore(map, OpenMode::kReadOnly);
    EXPECT_EQ(main->loadPosterior(),
              (std::vector<std::pair<std::int64_t, double>>{{-1, 0.25}, {2, 0.5}, {3, 0.25}}))
        << map;
  }
  auto side = sideWriter(back);
  side->useSideMemory(s2);
  EXPECT_EQ(side->loadPosterior(),
            (std::vector<std::pair<std::int64_t, double>>{{-1, 0.125}, {3, 0.875}}));
}

// A file has one writer: it holds the main line, no side session begins, and a side session a
// copy of a fleet map brought cannot be continued there.
TEST(PgFleetStore, AFileHasOneWriter) {
  const auto dir = placedb::testing::scratchDir("PgFleetStore_AFileHasOneWriter");
  const std::string path = (dir / "map.placedb").string();
  auto store = openMapStore(path, OpenMode::kReadWrite);
  EXPECT_FALSE(store->sharedByWriters());
  EXPECT_TRUE(store->claimMainLine());
  const auto s1 = store->beginSession("a", {}, "test");
  EXPECT_EQ(store->sessionMemory(s1), SessionMemory::kMainLine);
  EXPECT_EQ(codeOf([&] { store->beginSideSession("b", {}, "test"); }), ErrorCode::kInternal);
  EXPECT_EQ(codeOf([&] { store->useSideMemory(s1); }), ErrorCode::kInvalidArgument);
  testing::writeFrame(*store, s1, 0);
  EXPECT_EQ(store->reserveIds(IdKind::kFrame, 4, 1).first, 2);
}

}  // namespace
}  // namespace placedb::storage
