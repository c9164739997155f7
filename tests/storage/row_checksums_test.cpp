// Checksums beside BLOBs and resume state (schema 8): damage SQLite's page checks cannot see is
// refused when the row is read, naming the map, the table and the row.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>

#include <gtest/gtest.h>

#include "placedb/storage/migrations.h"
#include "placedb/storage/sqlite_map_store.h"
#include "storage_test_util.h"
#include "test_paths.h"

namespace placedb::storage {
namespace {

using testing::RawDb;

// Three frames of words, a place code, a state value and a small kd-forest.
std::string makeMap(const std::filesystem::path& dir) {
  const std::string path = (dir / "good.placedb").string();
  SqliteMapStore store(path, OpenMode::kReadWrite);
  const std::int64_t session = store.beginSession("test", {}, "test");
  for (int i = 0; i < 3; ++i) testing::writeFrame(store, session, i);
  store.putPlaceCode(1, {1, -2, 3, -4});
  store.putState("test.bytes", std::vector<std::uint8_t>{9, 8, 7});
  store.writeKdNodes({{0, 0, 1, 2, 3, 0.25}, {0, 1, 3, 4, 5, 0.5}}, {}, false);
  LocationWordDescriptors words;
  words.location_id = 2;
  words.dim = 8;
  words.word_ids = {5, 6};
  words.created_frames = {2, 2};
  words.descriptors.assign(16, 5.f);
  std::fill(words.descriptors.begin() + 8, words.descriptors.end(), 6.f);
  store.putLocationWordDescriptors(words);
  words.location_id = 3;
  words.word_ids = {9, 10};
  words.created_frames = {3, 3};
  store.putLocationWordDescriptors(words);
  return path;
}

std::string refusal(const std::string& path, const std::function<void(MapStore&)>& read) {
  try {
    SqliteMapStore store(path, OpenMode::kReadWrite);
    read(store);
  } catch (const StorageError& error) {
    EXPECT_EQ(error.code(), ErrorCode::kMapRefused) << error.what();
    return error.what();
  }
  return "";
}

void loadFloats(MapStore& store, std::vector<std::int64_t> ids) {
  std::vector<float> rows(ids.size() * 8);
  std::vector<std::int64_t> created(ids.size());
  store.loadFloatDescriptors(ids, 8, rows.data(), created.data());
}

// CRC-32C one bit at a time, from SCHEMA.md's definition alone (reflected polynomial
// 0x82F63B78, all ones in and out): whatever instructions placedb sums with, the stored sums must
// be these.
struct BitwiseCrc32c {
  std::uint32_t r = 0xFFFFFFFF;
  void bytes(const void* data, std::size_t size) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) {
      r ^= p[i];
      for (int bit = 0; bit < 8; ++bit) r = (r >> 1) ^ (0x82F63B78u & (0u - (r & 1u)));
    }
  }
  void integer(std::int64_t v) {
    unsigned char le[8];
    for (int i = 0; i < 8; ++i)
      le[i] = static_cast<unsigned char>(static_cast<std::uint64_t>(v) >> (8 * i));
    bytes(le, 8);
  }
  std::int64_t sum() const { return std::int64_t{~r}; }
};

TEST(RowChecksums, StoredSumsAreTheDocumentedCrc32c) {
  BitwiseCrc32c check;
  check.bytes("123456789", 9);
  ASSERT_EQ(check.sum(), 0xE3069283);  // the standard check value of CRC-32C
  const auto dir = placedb::testing::scratchDir("RowChecksumValues");
  const std::string path = (dir / "sums.placedb").string();
  // Lengths that are not multiples of 8, so that every tail of the sum is exercised.
  const std::vector<std::uint8_t> value{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11};
  const std::vector<std::int8_t> code{1, -2, 3, -4, 5};
  const std::vector<float> descriptor{0.5f, -0.25f, 1.f, 0.f, 3.f, -7.f, 0.125f, 2.f};
  {
    SqliteMapStore store(path, OpenMode::kReadWrite);
    const std::int64_t session = store.beginSession("test", {}, "test");
    testing::writeFrame(store, session, 0);
    store.insertWords({WordRecord::fromFloats(1000, std::nullopt, descriptor.data(), 8)});
    store.putState("k.odd", value);
    store.putPlaceCode(1, code);
    LocationWordDescriptors words;
    words.location_id = 1;
    words.dim = 8;
    words.word_ids = {1000};
    words.created_frames = {-1};
    words.descriptors = descriptor;
    store.putLocationWordDescriptors(words);
  }
  BitwiseCrc32c word;
  word.integer(1000);
  word.integer(-1);  // no created_frame
  word.integer(0);   // float32
  word.integer(8);
  word.bytes(descriptor.data(), descriptor.size() * sizeof(float));
  BitwiseCrc32c state;
  state.integer(5);
  state.bytes("k.odd", 5);
  state.bytes(value.data(), value.size());
  BitwiseCrc32c place;
  place.integer(1);
  place.bytes(code.data(), code.size());
  BitwiseCrc32c location_words;
  location_words.integer(1);
  location_words.integer(8);
  location_words.integer(1000);
  location_words.integer(-1);
  location_words.bytes(descriptor.data(), descriptor.size() * sizeof(float));
  // A location's references: its id, each reference's word and keypoint values (doubles as
  // their bits), then how many there are (testing::writeFrame's four of frame 0).
  BitwiseCrc32c refs;
  refs.integer(1);
  const auto real = [&refs](double v) {
    std::int64_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    refs.integer(bits);
  };
  for (int i = 0; i < 4; ++i) {
    refs.integer(i + 1);
    for (double v : {double(i), double(i), 2.0, 0.0, 1.0}) real(v);
  }
  refs.integer(4);
  RawDb db(path);
  EXPECT_EQ(db.rows("SELECT refs_digest FROM locations WHERE id = 1"),
            std::vector<std::string>{std::to_string(refs.sum())});
  EXPECT_EQ(db.rows("SELECT checksum FROM location_word_descriptors WHERE location_id = 1"),
            std::vector<std::string>{std::to_string(location_words.sum())});
  EXPECT_EQ(db.rows("SELECT checksum FROM words WHERE id = 1000"),
            std::vector<std::string>{std::to_string(word.sum())});
  EXPECT_EQ(db.rows("SELECT checksum FROM engine_state WHERE key = 'k.odd'"),
            std::vector<std::string>{std::to_string(state.sum())});
  EXPECT_EQ(db.rows("SELECT checksum FROM place_codes WHERE location_id = 1"),
            std::vector<std::string>{std::to_string(place.sum())});
}

TEST(RowChecksums, DamageInsideRowsIsRefusedNamingTheRow) {
  const auto dir = placedb::testing::scratchDir("RowChecksumsDamage");
  const std::string good = makeMap(dir);
  ASSERT_EQ(refusal(good,
                    [](MapStore& s) {
                      loadFloats(s, {1, 2, 5, 6});
                      s.loadWords({1, 12});
                      s.placeCodes();
                      s.locationWordDescriptors({2});
                      s.getState("test.bytes");
                      s.loadKdNodes();
                    }),
            "");

  struct Case {
    const char* sql;
    std::function<void(MapStore&)> read;
    const char* names;
  };
  const std::vector<Case> cases = {
      // One bit of one float.
      {"UPDATE words SET descriptor = CAST(substr(descriptor, 1, 4) || X'01' || "
       "substr(descriptor, 6) AS BLOB) WHERE id = 5",
       [](MapStore& s) { loadFloats(s, {5}); }, "words row 5"},
      {"UPDATE words SET descriptor = zeroblob(32) WHERE id = 6",
       [](MapStore& s) { s.loadWords({6}); }, "words row 6"},
      // Another row's descriptor with its checksum: the id is part of the sum.
      {"UPDATE words SET (descriptor, checksum) = (SELECT descriptor, checksum FROM words "
       "WHERE id = 1) WHERE id = 2",
       [](MapStore& s) {
         loadFloats(s, {1, 2});
       },
       "words row 2"},
      {"UPDATE words SET checksum = NULL WHERE id = 3", [](MapStore& s) { s.loadWords({3}); },
       "words row 3"},
      {"UPDATE place_codes SET code = X'01FE03FB' WHERE location_id = 1",
       [](MapStore& s) { s.placeCodes(); }, "place_codes row 1"},
      {"UPDATE place_codes SET code = X'01FE03FB' WHERE location_id = 1",
       [](MapStore& s) { s.placeCode(1); }, "place_codes row 1"},
      // One bit of a float the row copied from word 6; another location's words with their sum.
      {"UPDATE location_word_descriptors SET words = CAST(substr(words, 1, 40) || X'01' || "
       "substr(words, 42) AS BLOB) WHERE location_id = 2",
       [](MapStore& s) { s.locationWordDescriptors({2}); }, "location_word_descriptors row 2"},
      {"UPDATE location_word_descriptors SET (words, checksum) = (SELECT words, checksum FROM "
       "location_word_descriptors WHERE location_id = 3) WHERE location_id = 2",
       [](MapStore& s) {
         std::vector<float> rows(8);
         std::int64_t created = 0;
         s.loadLocationDescriptors({2}, {5}, 8, rows.data(), &created);
       },
       "location_word_descriptors row 2"},
      {"UPDATE engine_state SET value = X'090807FF' WHERE key = 'test.bytes'",
       [](MapStore& s) { s.getState("test.bytes"); }, "engine_state row 'test.bytes'"},
      {"UPDATE kd_nodes SET split_value = 0.75 WHERE tree = 0 AND node = 1",
       [](MapStore& s) { s.loadKdNodes(); }, "kd_nodes row (tree 0, node 1)"},
      {"DELETE FROM kd_nodes WHERE tree = 0 AND node = 1", [](MapStore& s) { s.loadKdNodes(); },
       "kd_nodes holds 1 rows where the map recorded 2"},
      {"DELETE FROM engine_state WHERE key = 'storage.kd_nodes.rows'",
       [](MapStore& s) { s.loadKdNodes(); }, "storage.kd_nodes.rows"},
  };
  int n = 0;
  for (const Case& c : cases) {
    const std::string path = (dir / ("d" + std::to_string(n++) + ".placedb")).string();
    std::filesystem::copy_file(good, path, std::filesystem::copy_options::overwrite_existing);
    RawDb(path).exec(c.sql);
    const std::string what = refusal(path, c.read);
    EXPECT_NE(what.find("map " + path + " damaged"), std::string::npos) << c.sql << ": " << what;
    EXPECT_NE(what.find(c.names), std::string::npos) << c.sql << ": " << what;
  }
}

// A value no extractor makes, written with a valid sum (by a placedb before checksums, say).
TEST(RowChecksums, NonFiniteDescriptorIsRefused) {
  const auto dir = placedb::testing::scratchDir("RowChecksumsNaN");
  const std::string path = makeMap(dir);
  {
    SqliteMapStore store(path, OpenMode::kReadWrite);
    std::vector<float> values(8, 1.0f);
    values[3] = std::numeric_limits<float>::quiet_NaN();
    store.insertWords({WordRecord::fromFloats(100, std::nullopt, values.data(), 8)});
  }
  const std::string what = refusal(path, [](MapStore& s) { loadFloats(s, {100}); });
  EXPECT_NE(what.find("words row 100 holds a value that is not a finite number"), std::string::npos)
      << what;
}

TEST(RowChecksums, KdNodeRowCountFollowsEveryWrite) {
  const auto dir = placedb::testing::scratchDir("RowChecksumsKdCount");
  const std::string path = (dir / "m.placedb").string();
  SqliteMapStore store(path, OpenMode::kReadWrite);
  const auto recorded = [&] { return std::stoll(*store.getStateText("storage.kd_nodes.rows")); };
  EXPECT_EQ(recorded(), 0);
  store.writeKdNodes({{0, 0, 1, 2, 0, 0.5}, {1, 0, 1, 2, 0, 0.5}}, {}, false);
  EXPECT_EQ(recorded(), 2);
  store.writeKdNodes({{0, 0, 1, 2, 1, 0.25}, {0, 1, 3, 4, 0, 0.5}}, {{1, 0}, {1, 7}}, false);
  EXPECT_EQ(recorded(), 2);
  EXPECT_EQ(store.loadKdNodes().size(), 2u);
  store.writeKdNodes({{2, 0, 1, 2, 0, 0.5}}, {}, /*replace_all=*/true);
  EXPECT_EQ(recorded(), 1);
  EXPECT_EQ(store.loadKdNodes().size(), 1u);
}

// A map of schema 7 gets every sum on its first read-write open, and is then guarded as well.
TEST(RowChecksums, OlderMapGetsChecksumsOnUpgrade) {
  const auto dir = placedb::testing::scratchDir("RowChecksumsUpgrade");
  const std::string path = (dir / "v7.placedb").string();
  buildMapAtVersion(path, 7);
  {
    RawDb db(path);
    db.exec(
        "INSERT INTO sessions (id, started_at, software_version, source) "
        "VALUES (1, '2026-01-01T00:00:00Z', 'old', 'src')");
    db.exec("INSERT INTO frames (id, session_id, source_index, outcome) VALUES (1, 1, 0, 0)");
    db.exec("INSERT INTO locations (id, session_id, weight, tier) VALUES (1, 1, 0, 1)");
    db.exec(
        "INSERT INTO words (id, created_frame, descriptor_type, dim, descriptor) "
        "VALUES (1, 1, 0, 8, zeroblob(32)), (2, NULL, 0, 8, zeroblob(32))");
    db.exec("INSERT INTO place_codes (location_id, code) VALUES (1, X'0102')");
    db.exec("INSERT INTO engine_state (key, value) VALUES ('a', 'text'), ('b', X'0001')");
    db.exec(
        "INSERT INTO kd_nodes (tree, node, left_child, right_child, split_dim, split_value) "
        "VALUES (0, 0, 1, 2, 3, 0.5)");
  }
  {
    SqliteMapStore store(path, OpenMode::kReadWrite);
    EXPECT_EQ(store.schemaVersion(), MapStore::currentSchemaVersion());
    loadFloats(store, {1, 2});
    EXPECT_EQ(store.placeCodes().size(), 1u);
    EXPECT_EQ(*store.getStateText("a"), "text");
    EXPECT_EQ(store.getState("b")->size(), 2u);
    EXPECT_EQ(store.loadKdNodes().size(), 1u);
  }
  RawDb db(path);
  for (const char* table : {"words", "place_codes", "engine_state", "kd_nodes"})
    EXPECT_EQ(db.rows(std::string("SELECT count(*) FROM ") + table + " WHERE checksum IS NULL"),
              std::vector<std::string>{"0"})
        << table;
  db.exec("UPDATE engine_state SET value = 'texT' WHERE key = 'a'");
  EXPECT_NE(refusal(path, [](MapStore& s) { s.getStateText("a"); }).find("engine_state row 'a'"),
            std::string::npos);
}

}  // namespace
}  // namespace placedb::storage
