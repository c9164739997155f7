// The descriptors of a location's words stored beside it (schema 13): what bringing a location
// back from long-term memory reads. Runs on both backends, as records_test.cpp: on a SQLite file
// in storage_tests and on a PostgreSQL database in pg_storage_tests (PLACEDB_RECORDS_ON_PG).
#include <filesystem>

#include <gtest/gtest.h>

#include "backend_fixture.h"
#include "placedb/storage/migrations.h"
#include "placedb/storage/sqlite_map_store.h"
#include "storage_test_util.h"
#include "test_paths.h"

namespace placedb::storage {
namespace {

constexpr int kDim = 8;

float valueOf(std::int64_t word, int k) { return static_cast<float>(word) + 0.125f * k; }

LocationWordDescriptors wordsOf(std::int64_t location, const std::vector<std::int64_t>& ids) {
  LocationWordDescriptors words;
  words.location_id = location;
  words.dim = kDim;
  for (std::int64_t id : ids) {
    words.word_ids.push_back(id);
    words.created_frames.push_back(id % 3 ? 1 : -1);
    for (int k = 0; k < kDim; ++k) words.descriptors.push_back(valueOf(id, k));
  }
  return words;
}

bool sameWords(const LocationWordDescriptors& a, const LocationWordDescriptors& b) {
  return a.location_id == b.location_id && a.dim == b.dim && a.word_ids == b.word_ids &&
         a.created_frames == b.created_frames && a.descriptors == b.descriptors;
}

class LocationWords : public testing::BackendTest {
 protected:
  void SetUp() override {
    BackendTest::SetUp();
    if (IsSkipped()) return;
    const std::int64_t session = store_->beginSession("test", {}, "test");
    // Words 1..40 in the words table; locations 1 and 2 hold some of them, 1 with its row.
    Transaction tx = store_->begin();
    FrameRecord frame;
    frame.id = 1;
    frame.session_id = session;
    store_->insertFrame(frame);
    std::vector<WordRecord> words;
    for (std::int64_t id = 1; id <= 40; ++id) {
      std::vector<float> values(kDim);
      for (int k = 0; k < kDim; ++k) values[k] = valueOf(id, k);
      words.push_back(WordRecord::fromFloats(
          id, id % 3 ? std::optional<std::int64_t>(1) : std::nullopt, values.data(), kDim));
    }
    store_->insertWords(words);
    store_->insertLocation({1, session, 0, Tier::kLtm, 1});
    store_->insertLocation({2, session, 0, Tier::kLtm, 1});
    tx.commit();
  }
};

TEST_P(LocationWords, RowsAreReadBackAsWrittenInTheOrderAsked) {
  store_->putLocationWordDescriptors(wordsOf(2, {5, 6, 30}));
  store_->putLocationWordDescriptors(wordsOf(1, {3, 9}));
  store_->putLocationWordDescriptors(wordsOf(1, {3, 9, 12}));  // written again: replaced
  const auto read = store_->locationWordDescriptors({2, 7, 1});
  ASSERT_EQ(read.size(), 2u) << "location 7 has no row";
  EXPECT_TRUE(sameWords(read[0], wordsOf(2, {5, 6, 30})));
  EXPECT_TRUE(sameWords(read[1], wordsOf(1, {3, 9, 12})));
  store_->deleteLocation(2);
  EXPECT_TRUE(store_->locationWordDescriptors({2}).empty()) << "deleted with its location";
}

// A retrieval's words come from the locations' rows; those no row holds (a location made
// before schema 13, an imported word) from the words table.
TEST_P(LocationWords, RetrievalReadsRowsThenTheWordsTable) {
  // Word 900 is in no words row: only location 1's row can give it.
  store_->putLocationWordDescriptors(wordsOf(1, {3, 7, 900}));
  const std::vector<std::int64_t> ids = {3, 7, 10, 900};
  std::vector<float> rows(ids.size() * kDim, -1.f);
  std::vector<std::int64_t> created(ids.size(), 99);
  store_->loadLocationDescriptors({1, 2}, ids, kDim, rows.data(), created.data());
  for (std::size_t i = 0; i < ids.size(); ++i) {
    SCOPED_TRACE("word " + std::to_string(ids[i]));
    for (int k = 0; k < kDim; ++k) EXPECT_EQ(rows[i * kDim + k], valueOf(ids[i], k));
    EXPECT_EQ(created[i], ids[i] % 3 ? 1 : -1);
  }
  auto code = [&](const std::vector<std::int64_t>& locations,
                  const std::vector<std::int64_t>& asked, int dim) {
    std::vector<float> out(asked.size() * kDim);
    std::vector<std::int64_t> made(asked.size());
    try {
      store_->loadLocationDescriptors(locations, asked, dim, out.data(), made.data());
    } catch (const Error& e) {
      return static_cast<int>(e.code());
    }
    return 0;
  };
  const int refused = static_cast<int>(ErrorCode::kMapRefused);
  EXPECT_EQ(code({2}, {900}, kDim), refused) << "without location 1's row, 900 is missing";
  EXPECT_EQ(code({1}, {3}, kDim + 1), refused) << "another dimension";
  EXPECT_EQ(code({1}, {7, 3}, kDim), static_cast<int>(ErrorCode::kInvalidArgument));
}

// The engine_state rows a location owns (its keypoints' descriptors, the view of its latest
// merged frame) go with it; another location's stay.
TEST_P(LocationWords, DeletingALocationDeletesItsEngineStateRows) {
  const std::vector<std::uint8_t> bytes = {1, 2, 3};
  for (std::int64_t id : {1, 2}) {
    store_->putState(locationKeypointsKey(id), bytes);
    store_->putState(locationLatestViewKey(id), bytes);
  }
  store_->deleteLocation(2);
  EXPECT_FALSE(store_->getState(locationKeypointsKey(2)));
  EXPECT_FALSE(store_->getState(locationLatestViewKey(2)));
  EXPECT_EQ(store_->getState(locationKeypointsKey(1)), bytes);
  EXPECT_EQ(store_->getState(locationLatestViewKey(1)), bytes);
}

// Its posterior entry goes with it (a row in a file, an element of the arrays on a server, schema
// 18); the others keep their order and values.
TEST_P(LocationWords, DeletingALocationDeletesItsPosteriorEntry) {
  using Posterior = std::vector<std::pair<std::int64_t, double>>;
  store_->putPosterior({{-1, 0.25}, {1, 0.75}});
  store_->deleteLocation(2);  // not in the posterior: it stays as it was
  EXPECT_EQ(store_->loadPosterior(), (Posterior{{-1, 0.25}, {1, 0.75}}));
  store_->putPosterior({{-1, 0.25}, {1, 0.25}, {2, 0.5}});
  store_->deleteLocation(1);
  EXPECT_EQ(store_->loadPosterior(), (Posterior{{-1, 0.25}, {2, 0.5}}));
}

#ifdef PLACEDB_RECORDS_ON_PG
INSTANTIATE_TEST_SUITE_P(Postgresql, LocationWords, ::testing::Values(std::string("postgresql")));
#else
INSTANTIATE_TEST_SUITE_P(Sqlite, LocationWords, ::testing::Values(std::string("sqlite")));

// A map of schema 12 gains the table, empty: its locations are read from the words table.
TEST(LocationWordsUpgrade, OlderMapGetsAnEmptyTable) {
  const auto dir = placedb::testing::scratchDir("LocationWordsUpgrade");
  const std::string path = (dir / "v12.placedb").string();
  buildMapAtVersion(path, 12);
  {
    SqliteMapStore store(path, OpenMode::kReadWrite);
    EXPECT_EQ(store.schemaVersion(), MapStore::currentSchemaVersion());
    EXPECT_TRUE(store.locationWordDescriptors({1}).empty());
  }
  EXPECT_EQ(testing::RawDb(path).rows("SELECT count(*) FROM location_word_descriptors"),
            std::vector<std::string>{"0"});
}
#endif

}  // namespace
}  // namespace placedb::storage
