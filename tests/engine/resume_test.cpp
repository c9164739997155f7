// Exact resume: a run stopped after any frame and resumed gives the same per-frame results as a
// run that never stopped, also when transfer and retrieval move locations between tiers.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <cstring>
#include <functional>

#include "engine_fixture.h"
#include "legacy_split_log.h"
#include "placedb/storage/migrations.h"
#include "placedb/storage/sqlite_map_store.h"
#include "vocabulary/vocabulary.h"

namespace placedb::testing {
namespace {

class ResumeTest : public ::testing::TestWithParam<int> {
 protected:
  void SetUp() override {
    seq_ = rtabmapSamples();
    if (!seq_) GTEST_SKIP() << "no rtabmap_samples under " << datasetsDir();
  }

  // Maps every frame, closing and reopening the map after each `stop_every` frames.
  // `on_close` sees the map file after each stop, before it is reopened.
  std::vector<Outcome> run(const std::string& name, const Options& options, int stop_every,
                           bool check_consistency,
                           const std::function<void(const std::string&)>& on_close = {},
                           int max_stops = -1) {
    auto path = scratchDir(name) / "map.placedb";
    removeMap(path);
    std::vector<Outcome> out;
    std::unique_ptr<Map> map;
    int stops = 0;
    for (std::size_t i = 0; i < seq_->images.size(); ++i) {
      if (!map) map = openForFrame(path, options, i, "rtabmap_samples");
      out.push_back(outcomeOf(map->process(seq_->images[i], i, seq_->paths[i])));
      if (check_consistency) {
        std::string problem = impl(*map).checkConsistency();
        EXPECT_EQ(problem, "") << "after frame " << i;
      }
      if (stop_every > 0 && (i + 1) % stop_every == 0 && (max_stops < 0 || stops < max_stops)) {
        ++stops;
        map.reset();  // destructor closes
        if (on_close) on_close(path.string());
      }
    }
    return out;
  }

  void expectSame(const std::vector<Outcome>& a, const std::vector<Outcome>& b) {
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
      SCOPED_TRACE("frame " + std::to_string(i));
      EXPECT_EQ(a[i].location, b[i].location);
      EXPECT_EQ(a[i].outcome, b[i].outcome);
      EXPECT_EQ(a[i].hypothesis, b[i].hypothesis);
      EXPECT_EQ(a[i].accepted, b[i].accepted);
      EXPECT_NEAR(a[i].posterior, b[i].posterior, 1e-6);
      EXPECT_NEAR(a[i].score, b[i].score, 1e-6);
      EXPECT_EQ(a[i].wm, b[i].wm);
      EXPECT_EQ(a[i].stm, b[i].stm);
      EXPECT_EQ(a[i].vocabulary, b[i].vocabulary);
      EXPECT_EQ(a[i].transferred, b[i].transferred);
      EXPECT_EQ(a[i].retrieved, b[i].retrieved);
      EXPECT_EQ(a[i].retrieved_by_search, b[i].retrieved_by_search);
    }
  }

  const Sequence* seq_ = nullptr;
};

TEST_P(ResumeTest, StoppedEveryTenthFrameEqualsStraightRun) {
  Options options;
  options.wm_max = GetParam();
  auto straight = run("straight" + std::to_string(GetParam()), options, 0, true);
  auto split = run("split" + std::to_string(GetParam()), options, 10, false);
  expectSame(straight, split);

  std::size_t transferred = 0, retrieved = 0, accepted = 0, found = 0;
  for (const auto& o : straight) {
    transferred += o.transferred;
    retrieved += o.retrieved;
    found += o.retrieved_by_search;
    accepted += o.accepted;
  }
  EXPECT_GT(accepted, 10u) << "the sequence should close loops";
  if (GetParam() > 0) {
    // The bound must really move locations both ways, or the test proves nothing about tiers.
    EXPECT_GT(transferred, 0u);
    EXPECT_GT(retrieved, 0u);
    EXPECT_GT(found, 0u) << "the LTM search must bring places back, or its resume is untested";
    for (const auto& o : straight) EXPECT_LE(o.wm, static_cast<std::size_t>(GetParam()));
  }
}

// The place-code search through the inverted file (memory/place_lists.h), its threshold set low
// so that it starts mid-run: stopped every seventh frame, before the lists are trained, at the
// frame that trains them and after, the run decides exactly as a straight one (a reopened map
// trains its lists on the same codes, those of the lowest location ids).
TEST_P(ResumeTest, StoppedAcrossThePlaceListsThresholdEqualsStraightRun) {
  if (GetParam() == 0) GTEST_SKIP() << "no place-code search without a bound";
  Options options;
  options.wm_max = GetParam();
  options.place_lists_from = 40;
  auto straight = run("straight_lists" + std::to_string(GetParam()), options, 0, true);
  std::string path;
  auto split = run("split_lists" + std::to_string(GetParam()), options, 7, false,
                   [&path](const std::string& closed) { path = closed; });
  expectSame(straight, split);

  // The lists were used: the map holds more codes than the threshold, and a search trains them.
  auto map = Map::open(path, options);
  ASSERT_GT(impl(*map).placeIndex().size(), 60u);
  std::size_t found = 0;
  for (const auto& o : straight) found += o.retrieved_by_search;
  EXPECT_GT(found, 0u);
  // A search of a reopened map trains its lists (the run's last frames did the same).
  const auto matches = impl(*map).placeIndex().search(std::vector<std::int8_t>(256, 1), 5,
                                                      [](std::int64_t) { return true; });
  EXPECT_FALSE(matches.empty());
  EXPECT_GE(impl(*map).placeIndex().lists(), 2u);
  EXPECT_EQ(impl(*map).placeIndex().probes(), 1u);
}

// Every location's words beside it (schema 13) are copies of its words' rows: the distinct words of
// its signature, with their descriptors and created frames as the words table holds them.
void expectWordRowsCopyWords(const std::string& path) {
  storage::SqliteMapStore store(path, storage::OpenMode::kReadOnly);
  std::vector<std::int64_t> locations;
  for (auto tier : {storage::Tier::kStm, storage::Tier::kWm, storage::Tier::kLtm})
    for (const auto& location : store.locationsInTier(tier)) locations.push_back(location.id);
  EXPECT_GT(locations.size(), 5u);
  for (std::int64_t id : locations) {
    const auto stored = store.locationWordDescriptors({id});
    ASSERT_EQ(stored.size(), 1u) << "location " << id;
    std::vector<std::int64_t> words;
    for (const auto& ref : store.loadWordRefs(id)) words.push_back(ref.word_id);
    std::sort(words.begin(), words.end());
    words.erase(std::unique(words.begin(), words.end()), words.end());
    ASSERT_EQ(stored[0].word_ids, words) << "location " << id;
    std::vector<float> descriptors(words.size() * 64);
    std::vector<std::int64_t> created(words.size());
    store.loadFloatDescriptors(words, 64, descriptors.data(), created.data());
    EXPECT_EQ(stored[0].descriptors, descriptors) << "location " << id;
    EXPECT_EQ(stored[0].created_frames, created) << "location " << id;
  }
}

// Locations without their words beside them, as in a map made before schema 13, are brought back
// from the words table: the same decisions.
TEST_P(ResumeTest, LocationsWithoutWordRowsResumeExactly) {
  if (GetParam() == 0) GTEST_SKIP() << "nothing is brought back without a bound";
  Options options;
  options.wm_max = GetParam();
  auto straight = run("straight_rows" + std::to_string(GetParam()), options, 0, false);
  int closes = 0;
  auto without = run("without_rows" + std::to_string(GetParam()), options, 20, true,
                     [&closes](const std::string& path) {
                       if (++closes == 1) expectWordRowsCopyWords(path);
                       sqlite3* db = nullptr;
                       ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
                       // As locations made before schema 13 are: no row, and none recorded.
                       EXPECT_EQ(sqlite3_exec(db,
                                              "DELETE FROM location_word_descriptors; "
                                              "UPDATE locations SET held = held & ~2",
                                              nullptr, nullptr, nullptr),
                                 SQLITE_OK);
                       sqlite3_close(db);
                     });
  expectSame(straight, without);
}

// A map as schema 14 stored it (no record of what each location's rows hold, no sums on the WM
// ages and the posterior), stopped every 20 frames: each reopen upgrades it, the migration fills
// the records in from the rows, and the run decides exactly as a straight one.
TEST_P(ResumeTest, SchemaFourteenMapGetsItsRowRecordsAndResumesExactly) {
  Options options;
  options.wm_max = GetParam();
  auto straight = run("straight_v14_" + std::to_string(GetParam()), options, 0, false);
  auto upgraded = run("upgraded_v14_" + std::to_string(GetParam()), options, 20, false,
                      [](const std::string& path) {
                        sqlite3* db = nullptr;
                        ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
                        for (const char* sql :
                             {"ALTER TABLE locations DROP COLUMN held",
                              "ALTER TABLE locations DROP COLUMN refs_digest",
                              "ALTER TABLE locations DROP COLUMN checksum",
                              "ALTER TABLE locations DROP COLUMN link_count",
                              "ALTER TABLE sessions DROP COLUMN settings_digest",
                              "ALTER TABLE wm_entries DROP COLUMN checksum",
                              "ALTER TABLE filter_posterior DROP COLUMN checksum",
                              "DROP TABLE kd_node_journal",  // schema 20: empty once the map closed
                              "PRAGMA user_version = 14"})
                          EXPECT_EQ(sqlite3_exec(db, sql, nullptr, nullptr, nullptr), SQLITE_OK)
                              << sql;
                        sqlite3_close(db);
                      });
  expectSame(straight, upgraded);
}

// Rewrites a closed map as schema 2 stored it: the kd-forest as a split log in engine_state
// chunks behind a version-1 header, no kd_nodes table.
void downgradeToSchemaTwo(const std::string& path) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE, nullptr), SQLITE_OK);
  auto exec = [&](const std::string& sql) {
    char* error = nullptr;
    ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &error), SQLITE_OK) << error;
  };
  auto blobOf = [](sqlite3_stmt* st, int column) {
    const auto* p = static_cast<const std::uint8_t*>(sqlite3_column_blob(st, column));
    return std::vector<std::uint8_t>(p, p + sqlite3_column_bytes(st, column));
  };
  sqlite3_stmt* st = nullptr;
  std::vector<vocab::ForestNode> nodes;
  ASSERT_EQ(sqlite3_prepare_v2(db,
                               "SELECT tree, node, left_child, right_child, split_dim, "
                               "split_value FROM kd_nodes",
                               -1, &st, nullptr),
            SQLITE_OK);
  while (sqlite3_step(st) == SQLITE_ROW)
    nodes.push_back({static_cast<std::uint8_t>(sqlite3_column_int(st, 0)),
                     static_cast<std::uint32_t>(sqlite3_column_int64(st, 1)),
                     static_cast<std::uint32_t>(sqlite3_column_int64(st, 2)),
                     static_cast<std::uint32_t>(sqlite3_column_int64(st, 3)),
                     static_cast<std::uint16_t>(sqlite3_column_int(st, 4)),
                     static_cast<float>(sqlite3_column_double(st, 5))});
  sqlite3_finalize(st);
  ASSERT_GT(nodes.size(), 50u);
  ASSERT_EQ(sqlite3_prepare_v2(db,
                               "SELECT value FROM engine_state WHERE key = "
                               "'vocabulary.header'",
                               -1, &st, nullptr),
            SQLITE_OK);
  ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
  const vocab::IndexState header = vocab::IndexState::deserialize(blobOf(st, 0));
  sqlite3_finalize(st);

  std::vector<std::uint8_t> v1;  // "PVIS", version 1, settings, next word id, no split in it
  auto put = [&v1](const auto& value) {
    std::uint8_t bytes[sizeof(value)];
    std::memcpy(bytes, &value, sizeof(value));
    v1.insert(v1.end(), bytes, bytes + sizeof(value));
  };
  for (char c : {'P', 'V', 'I', 'S'}) put(c);
  put(std::uint32_t(1));
  put(std::int32_t(header.dim));
  put(std::int32_t(header.kd_trees));
  put(std::int32_t(header.leaf_size));
  put(header.seed);
  put(header.next_word_id);
  put(std::uint64_t(0));
  const auto log = legacySplitLog(nodes, header.kd_trees, /*padding=*/25);
  std::vector<std::vector<std::uint8_t>> chunks;
  for (std::size_t i = 0; i < log.size(); ++i) {
    if (i % 1024 == 0) chunks.emplace_back();
    std::vector<std::uint8_t>& c = chunks.back();
    const auto& s = log[i];
    std::uint8_t bytes[11];
    std::memcpy(bytes, &s.tree, 1);
    std::memcpy(bytes + 1, &s.node, 4);
    std::memcpy(bytes + 5, &s.dim, 2);
    std::memcpy(bytes + 7, &s.value, 4);
    c.insert(c.end(), bytes, bytes + 11);
  }
  exec("BEGIN");
  ASSERT_EQ(
      sqlite3_prepare_v2(db, "INSERT OR REPLACE INTO engine_state (key, value) VALUES (?1, ?2)", -1,
                         &st, nullptr),
      SQLITE_OK);
  auto write = [&](const std::string& key, const std::vector<std::uint8_t>& value) {
    sqlite3_bind_text(st, 1, key.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_blob(st, 2, value.data(), static_cast<int>(value.size()), SQLITE_TRANSIENT);
    ASSERT_EQ(sqlite3_step(st), SQLITE_DONE);
    sqlite3_reset(st);
  };
  write("vocabulary.header", v1);
  for (std::size_t c = 0; c < chunks.size(); ++c) {
    char key[32];
    std::snprintf(key, sizeof key, "vocabulary.splits.%06u", static_cast<unsigned>(c % 1000000));
    write(key, chunks[c]);
  }
  sqlite3_finalize(st);
  exec("DROP VIEW v_kd_trees");
  exec("DROP TABLE kd_nodes");
  exec("DROP TABLE place_codes");  // schema 4
  exec("DROP TABLE wm_entries");
  exec("DELETE FROM engine_state WHERE key = 'place_codes.centres'");
  exec("ALTER TABLE sessions DROP COLUMN source_digest");  // schema 6
  exec("DROP VIEW v_loop_closure_poses");                  // schema 7
  for (const char* column : {"pose_qw", "pose_qx", "pose_qy", "pose_qz", "pose_tx", "pose_ty",
                             "pose_tz", "pose_inliers"})
    exec(std::string("ALTER TABLE hypotheses DROP COLUMN ") + column);
  exec("ALTER TABLE words DROP COLUMN checksum");  // schema 8
  exec("ALTER TABLE engine_state DROP COLUMN checksum");
  exec("DELETE FROM engine_state WHERE key = 'storage.kd_nodes.rows'");
  exec("DROP VIEW v_frames");  // schema 9
  exec("ALTER TABLE frames DROP COLUMN stamp_ns");
  exec(
      "CREATE VIEW v_frames AS SELECT f.id AS frame_id, f.session_id, f.source_index, "
      "f.source_path, CASE f.outcome WHEN 0 THEN 'new' WHEN 1 THEN 'merged' ELSE 'bad' END AS "
      "outcome, f.location_id, f.feature_count, f.words_created, f.vocabulary_size, f.wm_size, "
      "f.stm_size, f.mean_quantisation_error, f.features_ms, f.quantisation_ms, f.likelihood_ms, "
      "f.filter_ms, f.memory_ms, f.storage_ms, f.total_ms FROM frames f");
  exec("CREATE INDEX word_refs_by_word ON word_refs (word_id, location_id)");  // schema 10
  for (const char* table :
       {"session_memory", "session_posterior", "session_kd_nodes", "session_state", "id_blocks"})
    exec(std::string("DROP TABLE ") + table);                          // schema 11
  exec("DROP INDEX locations_by_created_frame");                       // schema 12
  exec("DROP TABLE location_word_descriptors");                        // schema 13
  exec("CREATE INDEX locations_by_tier ON locations (tier, weight)");  // schema 14
  exec("ALTER TABLE locations DROP COLUMN held");                      // schema 15
  exec("ALTER TABLE locations DROP COLUMN refs_digest");
  exec("ALTER TABLE locations DROP COLUMN checksum");
  exec("ALTER TABLE locations DROP COLUMN link_count");
  exec("ALTER TABLE sessions DROP COLUMN settings_digest");
  exec("ALTER TABLE filter_posterior DROP COLUMN checksum");
  exec("DROP TABLE kd_node_journal");  // schema 20
  exec("PRAGMA user_version = 2");
  exec("COMMIT");
  sqlite3_close(db);
}

// A map written by schema 2 (kd-forest as a split log, with the empty subtrees erased words left)
// converts when reopened and keeps closing the sequence's loops. The log written here numbers the
// nodes anew (in split order, as a log does), and a split's random dimension is drawn from its
// node id, so from there on the trees grow differently than in a run that never stopped: the
// runs are compared by the loops they accept, not frame by frame. Once converted, a further stop
// changes nothing.
TEST_P(ResumeTest, SchemaTwoMapConvertsAndResumes) {
  Options options;
  options.wm_max = GetParam();
  auto straight = run("straight_v2_" + std::to_string(GetParam()), options, 0, false);
  std::string map_path;
  auto converter = [&map_path](int convert_at_close) {
    return [&map_path, convert_at_close, closes = 0](const std::string& path) mutable {
      map_path = path;
      if (++closes == convert_at_close) downgradeToSchemaTwo(path);
    };
  };
  // Converted at the stop after 30 frames, stopped again after 60.
  auto once = run("converted_once_" + std::to_string(GetParam()), options, 30, true, converter(1));
  EXPECT_EQ(sqlCount(map_path, "PRAGMA user_version"), storage::MapStore::currentSchemaVersion());
  EXPECT_EQ(
      sqlCount(map_path, "SELECT count(*) FROM engine_state WHERE key LIKE 'vocabulary.splits%'"),
      0);
  EXPECT_GT(sqlCount(map_path, "SELECT count(*) FROM kd_nodes"), 50);
  EXPECT_EQ(sqlCount(map_path,
                     "SELECT count(*) FROM pragma_integrity_check WHERE "
                     "integrity_check <> 'ok'"),
            0);

  // The same conversion, then no further stop: equal to `once` frame by frame.
  auto converted_only = run("converted_only_" + std::to_string(GetParam()), options, 30, false,
                            converter(1), /*max_stops=*/1);
  expectSame(once, converted_only);

  std::size_t accepted_straight = 0, accepted_converted = 0;
  for (std::size_t i = 30; i < straight.size(); ++i) {
    accepted_straight += straight[i].accepted;
    accepted_converted += once[i].accepted;
  }
  EXPECT_GE(accepted_converted + 3, accepted_straight);
  EXPECT_LE(accepted_converted, accepted_straight + 3);
}

INSTANTIATE_TEST_SUITE_P(WorkingMemoryBound, ResumeTest, ::testing::Values(0, 12),
                         [](const auto& info) {
                           return info.param ? "wm_max_" + std::to_string(info.param)
                                             : std::string("unbounded");
                         });

}  // namespace
}  // namespace placedb::testing
