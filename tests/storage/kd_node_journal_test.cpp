// The kd-forest in a map file (schema 20): a frame's changes journalled, folded into kd_nodes a
// slice at a time. Whatever a reader, a crash, a rollback or a copy meets, the forest it reads is
// the one written.
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "placedb/storage/map_check.h"
#include "placedb/storage/map_copy.h"
#include "placedb/storage/sqlite_map_store.h"
#include "sqlite/kd_node_journal.h"
#include "storage_test_util.h"
#include "test_paths.h"

namespace placedb::storage {
namespace {

using detail::KdNodeChanges;
using detail::KdNodeKey;
using Forest = std::map<KdNodeKey, KdNodeRecord>;
using testing::RawDb;

bool sameNode(const KdNodeRecord& a, const KdNodeRecord& b) {
  return a.tree == b.tree && a.node == b.node && a.left_child == b.left_child &&
         a.right_child == b.right_child && a.split_dim == b.split_dim &&
         a.split_value == b.split_value;
}

void expectForest(const Forest& expected, const std::vector<KdNodeRecord>& read) {
  ASSERT_EQ(read.size(), expected.size());
  auto it = expected.begin();
  for (const KdNodeRecord& n : read) {
    ASSERT_TRUE(sameNode(n, it->second)) << "tree " << n.tree << " node " << n.node;
    ++it;
  }
}

// Frames of a growing forest as the engine's: mostly splits (new ids, across the whole range on
// four trees), some nodes changed again, a few deleted.
class FrameMaker {
 public:
  explicit FrameMaker(unsigned seed) : rng_(seed) {}
  KdNodeChanges next(const Forest& forest) {
    KdNodeChanges c;
    const int splits = 60 + static_cast<int>(rng_() % 80);
    for (int i = 0; i < splits; ++i) c.upserts.push_back(node(next_id_++));
    for (int i = 0; i < 5 && !forest.empty(); ++i) {
      auto it = forest.lower_bound({int(rng_() % 4), std::int64_t(rng_() % next_id_)});
      if (it == forest.end()) continue;
      if (i == 0)
        c.deletions.push_back(it->first);
      else
        c.upserts.push_back(node(it->first.second, it->first.first));
    }
    return c;
  }

 private:
  KdNodeRecord node(std::int64_t id, int tree = -1) {
    KdNodeRecord n;
    n.tree = tree >= 0 ? tree : static_cast<int>(rng_() % 4);
    // Leaf ids of a real forest split in any order: scatter the new ones over the range.
    n.node = tree >= 0 ? id : static_cast<std::int64_t>((id * 7919) % 200003);
    n.left_child = n.node * 2 + 1;
    n.right_child = n.node * 2 + 2;
    n.split_dim = static_cast<int>(rng_() % 64);
    n.split_value = std::ldexp(static_cast<double>(rng_()), -40) - 0.002;
    return n;
  }
  std::mt19937 rng_;
  std::int64_t next_id_ = 1;
};

void writeFrames(SqliteMapStore& store, FrameMaker& maker, Forest& model, int frames) {
  for (int f = 0; f < frames; ++f) {
    const KdNodeChanges c = maker.next(model);
    Transaction tx = store.begin();
    store.writeKdNodes(c.upserts, c.deletions, false);
    tx.commit();
    detail::applyKdNodeChanges(c, &model);
  }
}

std::int64_t count(const std::string& path, const std::string& table) {
  RawDb db(path);
  return std::stoll(db.rows("SELECT count(*) FROM " + table).at(0));
}

// The map as a crash would leave it: the file and its log as they are between two frames.
std::string crashCopy(const std::string& path, const std::filesystem::path& dir) {
  const std::string copy = (dir / "crashed.placedb").string();
  std::filesystem::copy_file(path, copy);
  std::filesystem::copy_file(path + "-wal", copy + "-wal");
  return copy;
}

TEST(KdNodeJournal, ChangesPackAndUnpackExactly) {
  KdNodeChanges c;
  c.deletions = {{0, 5}, {255, std::numeric_limits<std::int64_t>::max()}};
  c.upserts.push_back({3, 0, 1, 2, 65535, -0.0});
  c.upserts.push_back({1, 77, -1, 1LL << 40, 0, std::nextafter(0.25, 1.0)});
  const std::vector<std::uint8_t> bytes = detail::packKdNodeChanges(c);
  KdNodeChanges back;
  ASSERT_TRUE(detail::unpackKdNodeChanges(bytes.data(), bytes.size(), &back));
  EXPECT_EQ(back.deletions, c.deletions);
  ASSERT_EQ(back.upserts.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) EXPECT_TRUE(sameNode(back.upserts[i], c.upserts[i]));
  EXPECT_TRUE(std::signbit(back.upserts[0].split_value));

  KdNodeChanges ignored;
  EXPECT_FALSE(detail::unpackKdNodeChanges(bytes.data(), bytes.size() - 1, &ignored));
  std::vector<std::uint8_t> bad = bytes;
  bad[0] = 7;  // neither a deletion nor an upsert
  EXPECT_FALSE(detail::unpackKdNodeChanges(bad.data(), bad.size(), &ignored));
  KdNodeChanges upsert_first;
  upsert_first.upserts = c.upserts;
  std::vector<std::uint8_t> swapped = detail::packKdNodeChanges(upsert_first);
  const std::vector<std::uint8_t> deletion = detail::packKdNodeChanges({{{0, 5}}, {}});
  swapped.insert(swapped.end(), deletion.begin(), deletion.end());
  EXPECT_FALSE(detail::unpackKdNodeChanges(swapped.data(), swapped.size(), &ignored));
}

TEST(KdNodeJournal, EveryPendingChangeIsFoldedWithinOneSweep) {
  // The journal keeps a row only while a change in it is pending, so the fold must reach every
  // node within one sweep, whatever its id: a far one (2^40) too, and quickly.
  detail::PendingKdNodes pending;
  Forest latest;
  std::mt19937 rng(7);
  std::int64_t seq = 1;
  for (; seq <= 40; ++seq) {
    KdNodeChanges c;
    for (int i = 0; i < 30; ++i) {
      KdNodeRecord n;
      n.tree = static_cast<int>(rng() % 3);
      n.node = static_cast<std::int64_t>(rng() % 5000);
      n.split_value = static_cast<double>(seq);
      c.upserts.push_back(n);
    }
    if (seq == 20) c.deletions.push_back({1, std::int64_t{1} << 40});
    if (seq == 10) c.upserts.push_back({1, std::int64_t{1} << 40, 1, 2, 3, 0.5});
    pending.record(seq, c);
    detail::applyKdNodeChanges(c, &latest);
  }
  EXPECT_EQ(pending.oldestNeeded(seq), 1);
  Forest folded;
  std::set<KdNodeKey> deleted;
  for (int call = 0; call <= detail::PendingKdNodes::kSweepFrames && !pending.empty(); ++call) {
    const KdNodeChanges slice = pending.takeNextSlice();
    for (const KdNodeKey& key : slice.deletions) EXPECT_TRUE(deleted.insert(key).second);
    for (const KdNodeRecord& n : slice.upserts)
      EXPECT_TRUE(folded.emplace(KdNodeKey{n.tree, n.node}, n).second) << "taken twice";
  }
  EXPECT_TRUE(pending.empty());
  EXPECT_EQ(pending.oldestNeeded(seq), seq);
  EXPECT_EQ(deleted, (std::set<KdNodeKey>{{1, std::int64_t{1} << 40}}));
  expectForest(latest, [&] {
    std::vector<KdNodeRecord> out;
    for (const auto& [key, n] : folded) out.push_back(n);
    return out;
  }());
}

TEST(KdNodeJournal, ReadersCrashesAndCloseSeeTheForestWritten) {
  const auto dir = placedb::testing::scratchDir("KdNodeJournalReaders");
  const std::string path = (dir / "map.placedb").string();
  Forest model;
  FrameMaker maker(1);
  auto store = std::make_unique<SqliteMapStore>(path, OpenMode::kReadWrite);
  for (int round = 0; round < 8; ++round) {
    writeFrames(*store, maker, model, 100);
    SqliteMapStore reader(path, OpenMode::kReadOnly);
    expectForest(model, reader.loadKdNodes());
  }
  // A frame folds a slice, not its own changes: most of the last frames' are still journalled,
  // and the journal holds about one sweep of frames, not the whole history.
  const std::int64_t journal = count(path, "kd_node_journal");
  EXPECT_GT(journal, 20);
  EXPECT_LE(journal, 2 * detail::PendingKdNodes::kSweepFrames + 1);
  EXPECT_LT(count(path, "kd_nodes"), static_cast<std::int64_t>(model.size()));

  // A crash between frames: the next writer reads the journal, then maps on.
  const std::string crashed = crashCopy(path, dir);
  {
    Forest after = model;
    FrameMaker more(2);
    SqliteMapStore resumed(crashed, OpenMode::kReadWrite);
    expectForest(after, resumed.loadKdNodes());
    writeFrames(resumed, more, after, 150);
    expectForest(after, resumed.loadKdNodes());
    SqliteMapStore reader(crashed, OpenMode::kReadOnly);
    expectForest(after, reader.loadKdNodes());
  }
  // A clean close leaves the whole forest in kd_nodes, for SQL readers.
  store.reset();
  EXPECT_EQ(count(path, "kd_node_journal"), 0);
  EXPECT_EQ(count(path, "kd_nodes"), static_cast<std::int64_t>(model.size()));
  RawDb raw(path);
  EXPECT_EQ(raw.rows("SELECT value FROM engine_state WHERE key = 'storage.kd_nodes.rows'").at(0),
            std::to_string(model.size()));
  SqliteMapStore reopened(path, OpenMode::kReadOnly);
  expectForest(model, reopened.loadKdNodes());
  EXPECT_TRUE(checkMap(path).ok());
}

TEST(KdNodeJournal, ACleanEndOfSessionFoldsTheJournal) {
  const auto dir = placedb::testing::scratchDir("KdNodeJournalEndSession");
  const std::string path = (dir / "map.placedb").string();
  Forest model;
  FrameMaker maker(6);
  SqliteMapStore store(path, OpenMode::kReadWrite);
  const std::int64_t first = store.beginSession("test", {}, "test");
  writeFrames(store, maker, model, 100);
  store.endSession(first, false);  // a writer that stopped on an error: nothing more is written
  EXPECT_GT(count(path, "kd_node_journal"), 0);
  const std::int64_t second = store.beginSession("test", {}, "test");
  writeFrames(store, maker, model, 100);
  store.endSession(second, true);
  EXPECT_EQ(count(path, "kd_node_journal"), 0);
  EXPECT_EQ(count(path, "kd_nodes"), static_cast<std::int64_t>(model.size()));
  expectForest(model, store.loadKdNodes());
}

TEST(KdNodeJournal, ARolledBackFrameLeavesTheCommittedForest) {
  const auto dir = placedb::testing::scratchDir("KdNodeJournalRollback");
  const std::string path = (dir / "map.placedb").string();
  Forest model;
  FrameMaker maker(3);
  {
    SqliteMapStore store(path, OpenMode::kReadWrite);
    writeFrames(store, maker, model, 300);
    {
      // A frame that fails after its forest changes (a full disk at commit, say).
      Forest ignored = model;
      const KdNodeChanges lost = maker.next(ignored);
      Transaction tx = store.begin();
      store.writeKdNodes(lost.upserts, lost.deletions, false);
      tx.rollback();
    }
    writeFrames(store, maker, model, 300);
    expectForest(model, store.loadKdNodes());
  }
  SqliteMapStore reopened(path, OpenMode::kReadOnly);
  expectForest(model, reopened.loadKdNodes());
}

TEST(KdNodeJournal, ACopyOfAJournalledMapHoldsTheWholeForest) {
  const auto dir = placedb::testing::scratchDir("KdNodeJournalCopy");
  const std::string path = (dir / "map.placedb").string();
  Forest model;
  FrameMaker maker(4);
  SqliteMapStore store(path, OpenMode::kReadWrite);
  store.beginSession("test", {}, "test");
  writeFrames(store, maker, model, 400);
  ASSERT_GT(count(path, "kd_node_journal"), 0);
  const std::string copy = (dir / "copy.placedb").string();
  {
    SqliteMapStore to(copy, OpenMode::kReadWrite);
    copyMap(store, to);
  }
  EXPECT_EQ(count(copy, "kd_node_journal"), 0);
  SqliteMapStore copied(copy, OpenMode::kReadOnly);
  expectForest(model, copied.loadKdNodes());
}

TEST(KdNodeJournal, ADamagedJournalRowIsRefusedAndFoundByCheck) {
  const auto dir = placedb::testing::scratchDir("KdNodeJournalDamage");
  const std::string path = (dir / "map.placedb").string();
  Forest model;
  FrameMaker maker(5);
  SqliteMapStore store(path, OpenMode::kReadWrite);
  writeFrames(store, maker, model, 200);
  const std::string crashed = crashCopy(path, dir);
  std::string seq;
  {
    RawDb raw(crashed);
    seq = raw.rows("SELECT max(seq) FROM kd_node_journal").at(0);
    // One byte of a split value, as a bad sector or a hand edit might change it.
    raw.exec(
        "UPDATE kd_node_journal SET changes = CAST(substr(changes, 1, 30) || x'7f' || "
        "substr(changes, 32) AS BLOB) WHERE seq = " +
        seq);
  }
  try {
    SqliteMapStore opened(crashed, OpenMode::kReadOnly);
    opened.loadKdNodes();
    ADD_FAILURE() << "a damaged journal row was read";
  } catch (const StorageError& e) {
    EXPECT_EQ(e.code(), ErrorCode::kMapRefused);
    EXPECT_NE(std::string(e.what()).find("kd_node_journal"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(crashed), std::string::npos) << e.what();
  }
  const CheckReport report = checkMap(crashed);
  ASSERT_EQ(report.findings_total, 1);
  EXPECT_EQ(report.findings[0].table, "kd_node_journal");
  EXPECT_EQ(report.findings[0].row, seq);
}

}  // namespace
}  // namespace placedb::storage
