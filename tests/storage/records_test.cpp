// Every kind of record written and read back; constraints and read-only access. The Records
// tests run on both backends: on a SQLite file in storage_tests, and on a PostgreSQL database
// in pg_storage_tests, which compiles this file again with PLACEDB_RECORDS_ON_PG.
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <functional>

#include <gtest/gtest.h>

#include "backend_fixture.h"
#include "placedb/storage/sqlite_map_store.h"
#include "storage_test_util.h"
#include "test_paths.h"

namespace placedb::storage {
namespace {

class Records : public testing::BackendTest {
 protected:
  void SetUp() override {
    BackendTest::SetUp();
    if (IsSkipped()) return;
    session_ = store_->beginSession("/data/lip6", {{"T_loop", "0.11"}, {"wm_max", "300"}}, "0.1.0");
  }

  FrameRecord sampleFrame(std::int64_t index) const {
    FrameRecord f;
    f.session_id = session_;
    f.source_index = index;
    f.source_path = "frames/" + std::to_string(index) + ".png";
    f.outcome = FrameOutcome::kMerged;
    f.timings = {1.5, 2.5, 3.5, 4.5, 5.5, 6.5, 24.0};
    f.stats = {400, 37, 12000, 150, 10, 0.125};
    return f;
  }

  std::int64_t session_ = 0;
};

TEST_P(Records, Sessions) {
  EXPECT_EQ(store_->settings(session_),
            (std::map<std::string, std::string>{{"T_loop", "0.11"}, {"wm_max", "300"}}));
  auto last = store_->lastSession();
  ASSERT_TRUE(last);
  EXPECT_EQ(last->id, session_);
  EXPECT_EQ(last->source, "/data/lip6");
  EXPECT_EQ(last->software_version, "0.1.0");
  EXPECT_FALSE(last->ended_at);
  EXPECT_FALSE(last->clean_close);
  EXPECT_EQ(last->started_at.size(), std::string("2026-01-01T00:00:00.000Z").size());
  store_->endSession(session_, true);
  const auto second = store_->beginSession("/data/other", {}, "0.2.0");
  const auto all = store_->sessions();
  ASSERT_EQ(all.size(), 2u);
  EXPECT_TRUE(all[0].clean_close);
  EXPECT_TRUE(all[0].ended_at);
  EXPECT_EQ(all[1].id, second);
  EXPECT_EQ(store_->lastSession()->id, second);
  EXPECT_TRUE(store_->settings(second).empty());
  EXPECT_THROW(store_->endSession(999, true), Error);
  store_->reopenSession(session_);  // resuming the first session
  EXPECT_FALSE(store_->sessions()[0].ended_at);
  EXPECT_FALSE(store_->sessions()[0].clean_close);
  EXPECT_THROW(store_->reopenSession(999), Error);
}

TEST_P(Records, FramesWithAssignedAndGivenIds) {
  EXPECT_FALSE(store_->lastFrameIndex(session_));
  FrameRecord first = sampleFrame(7);
  const auto first_id = store_->insertFrame(first);
  FrameRecord second = sampleFrame(3);
  second.id = 100;
  second.outcome = FrameOutcome::kBad;
  EXPECT_EQ(store_->insertFrame(second), 100);
  const auto frames = store_->frames(session_);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].id, 100);  // ordered by source index
  EXPECT_EQ(frames[0].outcome, FrameOutcome::kBad);
  const FrameRecord& back = frames[1];
  EXPECT_EQ(back.id, first_id);
  EXPECT_EQ(back.source_path, "frames/7.png");
  EXPECT_EQ(back.outcome, FrameOutcome::kMerged);
  EXPECT_FALSE(back.location_id);
  EXPECT_DOUBLE_EQ(back.timings.likelihood_ms, 3.5);
  EXPECT_DOUBLE_EQ(back.timings.storage_ms, 6.5);
  EXPECT_DOUBLE_EQ(back.timings.total_ms, 24.0);
  EXPECT_EQ(back.stats.words_created, 37);
  EXPECT_EQ(back.stats.vocabulary_size, 12000);
  EXPECT_EQ(back.stats.stm_size, 10);
  EXPECT_DOUBLE_EQ(back.stats.mean_quantisation_error, 0.125);
  EXPECT_EQ(store_->lastFrameIndex(session_), 7);
  EXPECT_EQ(store_->frameCount(), 2);
  EXPECT_EQ(store_->frameCount(session_), 2);
  EXPECT_EQ(store_->frame(100)->source_index, 3);
  // The same source index twice in a session is a typed error naming the statement.
  try {
    store_->insertFrame(sampleFrame(7));
    FAIL() << "duplicate frame accepted";
  } catch (const StorageError& error) {
    EXPECT_EQ(error.code(), ErrorCode::kStorage);
    EXPECT_NE(error.sql().find("INSERT INTO frames"), std::string::npos);
  }
}

TEST_P(Records, LocationsTiersAndCoverage) {
  {
    Transaction tx = store_->begin();
    for (std::int64_t i = 1; i <= 3; ++i) {
      FrameRecord f = sampleFrame(i);
      f.id = i;
      f.location_id = i == 3 ? 2 : i;  // frame 3 merged into location 2
      store_->insertFrame(f);
    }
    store_->insertLocation({1, session_, 1, Tier::kStm, 1});
    store_->insertLocation({2, session_, 0, Tier::kStm, 2});
    store_->addCoveredFrame(1, 1);
    store_->addCoveredFrame(2, 2);
    store_->addCoveredFrame(2, 3);
    store_->addCoveredFrame(2, 3);  // again: no duplicate
    tx.commit();
  }
  store_->updateWeight(2, 5);
  store_->setTier({1, 2}, Tier::kWm);
  store_->setTier({1}, Tier::kLtm);
  auto location = store_->location(2);
  ASSERT_TRUE(location);
  EXPECT_EQ(location->weight, 5);
  EXPECT_EQ(location->tier, Tier::kWm);
  EXPECT_EQ(location->created_frame, 2);
  EXPECT_EQ(location->session_id, session_);
  EXPECT_FALSE(store_->location(9));
  EXPECT_EQ(store_->coveredFrames(2), (std::vector<std::int64_t>{2, 3}));
  const auto covered = store_->coveredFrames(std::vector<std::int64_t>{1, 2});
  EXPECT_EQ(covered.at(1), (std::vector<std::int64_t>{1}));
  EXPECT_EQ(covered.at(2).size(), 2u);
  const auto wm = store_->locationsInTier(Tier::kWm);
  ASSERT_EQ(wm.size(), 1u);
  EXPECT_EQ(wm[0].id, 2);
  EXPECT_EQ(wm[0].weight, 5);
  EXPECT_EQ(store_->locationsInTier(Tier::kLtm).size(), 1u);
  EXPECT_TRUE(store_->locationsInTier(Tier::kStm).empty());
  EXPECT_THROW(store_->updateWeight(42, 1), Error);

  store_->deleteLocation(2);
  EXPECT_FALSE(store_->location(2));
  EXPECT_TRUE(store_->coveredFrames(2).empty());
  EXPECT_FALSE(store_->frame(3)->location_id);  // the frame stays, pointing nowhere
  EXPECT_EQ(store_->locationCount(), 1);
}

TEST_P(Records, WordsAndReferences) {
  Transaction tx = store_->begin();
  FrameRecord f = sampleFrame(0);
  f.id = 1;
  store_->insertFrame(f);
  store_->insertLocation({1, session_, 0, Tier::kWm, 1});
  store_->insertLocation({2, session_, 0, Tier::kWm, 1});
  std::vector<WordRecord> words;
  for (std::int64_t id = 1; id <= 5; ++id) {
    std::vector<float> values(64);
    for (int k = 0; k < 64; ++k) values[k] = static_cast<float>(id) + k * 0.25f;
    words.push_back(WordRecord::fromFloats(id, std::int64_t{1}, values.data(), 64));
  }
  WordRecord binary;
  binary.id = 6;
  binary.type = DescriptorKind::kBinary8U;
  binary.dim = 32;
  binary.descriptor.assign(32, 0xA5);
  words.push_back(binary);
  store_->insertWords(words);
  store_->insertWordRefs(
      1, {{1, 10.5f, 20.25f, 12, 90, 0.5f}, {2, 1, 2, 3, 4, 5}, {1, 7, 8, 9, 10, 11}});
  store_->insertWordRefs(1, {{6, 0, 0, 1, -1, 2}});  // appended after the first three
  store_->insertWordRefs(2, {{2, 0, 0, 1, -1, 2}, {3, 0, 0, 1, -1, 2}});
  tx.commit();

  EXPECT_EQ(store_->wordCount(), 6);
  EXPECT_EQ(store_->maxWordId(), 6);
  const auto loaded = store_->loadWords({5, 42, 6, 1});
  ASSERT_EQ(loaded.size(), 3u);
  EXPECT_EQ(loaded[0].id, 5);
  EXPECT_EQ(loaded[0].floats(), words[4].floats());
  EXPECT_EQ(loaded[0].created_frame, 1);
  EXPECT_EQ(loaded[1].type, DescriptorKind::kBinary8U);
  EXPECT_EQ(loaded[1].descriptor, binary.descriptor);
  EXPECT_THROW(loaded[1].floats(), Error);
  EXPECT_EQ(loaded[2].id, 1);

  const auto refs = store_->loadWordRefs(1);
  ASSERT_EQ(refs.size(), 4u);
  EXPECT_EQ(refs[0].word_id, 1);
  EXPECT_FLOAT_EQ(refs[0].x, 10.5f);
  EXPECT_FLOAT_EQ(refs[0].y, 20.25f);
  EXPECT_FLOAT_EQ(refs[0].size, 12);
  EXPECT_FLOAT_EQ(refs[0].angle, 90);
  EXPECT_FLOAT_EQ(refs[0].response, 0.5f);
  EXPECT_EQ(refs[2].word_id, 1);
  EXPECT_FLOAT_EQ(refs[2].response, 11);
  EXPECT_EQ(refs[3].word_id, 6);
  EXPECT_EQ(store_->wordsOfLocations({1, 2}), (std::vector<std::int64_t>{1, 2, 3, 6}));
  EXPECT_EQ(store_->locationsOfWord(2), (std::vector<std::int64_t>{1, 2}));
  EXPECT_EQ(store_->locationsOfWord(1), (std::vector<std::int64_t>{1}));

  store_->replaceWordRefs(1, {{5, 1, 1, 1, 1, 1}});
  const auto many = store_->loadWordRefs(std::vector<std::int64_t>{1, 2});
  ASSERT_EQ(many.at(1).size(), 1u);
  EXPECT_EQ(many.at(1)[0].word_id, 5);
  EXPECT_EQ(many.at(2).size(), 2u);
  EXPECT_TRUE(store_->locationsOfWord(1).empty());

  WordRecord wrong_size = WordRecord::fromFloats(7, std::nullopt, words[0].floats().data(), 64);
  wrong_size.dim = 63;
  EXPECT_THROW(store_->insertWords({wrong_size}), Error);
}

// The bulk loads that restore working memory on open: descriptors straight into one matrix
// (walking the table across short gaps, seeking across long ones) and bare signatures.
TEST_P(Records, BulkDescriptorAndSignatureLoads) {
  constexpr int kDim = 8;
  auto value = [](std::int64_t id, int k) { return static_cast<float>(id) * 10.f + k; };
  {
    Transaction tx = store_->begin();
    FrameRecord f = sampleFrame(0);
    f.id = 1;
    store_->insertFrame(f);
    std::vector<WordRecord> words;
    for (std::int64_t id = 1; id <= 200; ++id) {
      std::vector<float> values(kDim);
      for (int k = 0; k < kDim; ++k) values[k] = value(id, k);
      words.push_back(WordRecord::fromFloats(
          id, id % 2 ? std::optional<std::int64_t>(1) : std::nullopt, values.data(), kDim));
    }
    std::vector<float> wide(kDim + 1, 0.f);
    words.push_back(WordRecord::fromFloats(300, std::nullopt, wide.data(), kDim + 1));
    store_->insertWords(words);
    store_->insertLocation({1, session_, 0, Tier::kWm, 1});
    store_->insertLocation({2, session_, 0, Tier::kWm, 1});
    store_->insertWordRefs(1, {{7, 0, 0, 1, 0, 1}, {3, 0, 0, 1, 0, 1}, {7, 0, 0, 1, 0, 1}});
    store_->insertWordRefs(2, {{150, 0, 0, 1, 0, 1}});
    tx.commit();
  }
  const auto snapshot = store_->readSnapshot();
  // Neighbours, a gap of 2, gaps far beyond the walk's reach, and the last word.
  const std::vector<std::int64_t> ids = {1, 2, 3, 6, 60, 61, 180, 200};
  std::vector<float> rows(ids.size() * kDim, -1.f);
  std::vector<std::int64_t> created(ids.size(), 99);
  store_->loadFloatDescriptors(ids, kDim, rows.data(), created.data());
  for (std::size_t i = 0; i < ids.size(); ++i) {
    SCOPED_TRACE("word " + std::to_string(ids[i]));
    for (int k = 0; k < kDim; ++k) EXPECT_EQ(rows[i * kDim + k], value(ids[i], k));
    EXPECT_EQ(created[i], ids[i] % 2 ? 1 : -1);
  }
  store_->loadFloatDescriptors({}, kDim, nullptr, nullptr);  // nothing asked, nothing touched
  // Ids that fill most of their range (a server reads them as the range and skips the others).
  const std::vector<std::int64_t> dense = {2, 3, 4, 6, 7, 8};
  std::vector<float> dense_rows(dense.size() * kDim, -1.f);
  std::vector<std::int64_t> dense_created(dense.size(), 99);
  store_->loadFloatDescriptors(dense, kDim, dense_rows.data(), dense_created.data());
  for (std::size_t i = 0; i < dense.size(); ++i) {
    SCOPED_TRACE("word " + std::to_string(dense[i]) + " of a dense range");
    for (int k = 0; k < kDim; ++k) EXPECT_EQ(dense_rows[i * kDim + k], value(dense[i], k));
    EXPECT_EQ(dense_created[i], dense[i] % 2 ? 1 : -1);
  }

  auto code = [&](const std::vector<std::int64_t>& asked) {
    std::vector<float> out(asked.size() * kDim);
    std::vector<std::int64_t> made(asked.size());
    try {
      store_->loadFloatDescriptors(asked, kDim, out.data(), made.data());
    } catch (const Error& e) {
      return static_cast<int>(e.code());
    }
    return 0;  // no error
  };
  const int refused = static_cast<int>(ErrorCode::kMapRefused);
  EXPECT_EQ(code({5, 201}), refused) << "a missing word past the end";
  EXPECT_EQ(code({5, 250, 260}), refused) << "a missing word in a gap";
  EXPECT_EQ(code({198, 199, 200, 201}), refused) << "a missing word past the end of a dense range";
  EXPECT_EQ(code({200, 300}), refused) << "another dimension";
  EXPECT_EQ(code({6, 5}), static_cast<int>(ErrorCode::kInvalidArgument)) << "unsorted ids";

  const auto signatures = store_->loadWordIds({1, 2, 3});
  EXPECT_EQ(signatures.at(1), (std::vector<std::int64_t>{7, 3, 7})) << "insertion order, repeats";
  EXPECT_EQ(signatures.at(2), (std::vector<std::int64_t>{150}));
  EXPECT_TRUE(signatures.at(3).empty());
}

TEST_P(Records, LinksStoredOncePerPairAndType) {
  store_->insertFrame([&] {
    auto f = sampleFrame(0);
    f.id = 1;
    return f;
  }());
  for (std::int64_t id = 1; id <= 4; ++id) {
    store_->insertLocation({id, session_, 0, id == 3 ? Tier::kLtm : Tier::kWm, 1});
  }
  store_->insertLink(2, 1, LinkType::kNeighbour, std::nullopt);
  store_->insertLink(1, 2, LinkType::kNeighbour, 0.5);  // same pair: updates the score
  store_->insertLink(1, 2, LinkType::kLoopClosure, 0.9);
  store_->insertLink(3, 2, LinkType::kNeighbour, std::nullopt);
  store_->insertLink(4, 2, LinkType::kMerge, 1.0);
  EXPECT_THROW(store_->insertLink(2, 2, LinkType::kNeighbour, std::nullopt), Error);

  const auto links = store_->links(2);
  ASSERT_EQ(links.size(), 4u);
  EXPECT_EQ(links[0].location_a, 1);
  EXPECT_EQ(links[0].location_b, 2);
  EXPECT_EQ(links[0].type, LinkType::kNeighbour);
  EXPECT_EQ(links[0].score, 0.5);
  EXPECT_EQ(links[1].type, LinkType::kLoopClosure);
  EXPECT_EQ(links[2].location_a, 2);
  EXPECT_EQ(links[2].location_b, 3);
  EXPECT_FALSE(links[2].score);
  EXPECT_EQ(store_->links(1).size(), 2u);
  EXPECT_EQ(store_->linkedInTier(2, Tier::kLtm), (std::vector<std::int64_t>{3}));
  EXPECT_EQ(store_->linkedInTier(2, Tier::kWm), (std::vector<std::int64_t>{1, 4}));
  EXPECT_EQ(store_->linkedInTier(2, Tier::kWm, LinkType::kMerge), (std::vector<std::int64_t>{4}));
  EXPECT_TRUE(store_->linkedInTier(2, Tier::kLtm, LinkType::kLoopClosure).empty());
  const auto neighbours = store_->linksOfType(LinkType::kNeighbour);
  ASSERT_EQ(neighbours.size(), 2u);
  EXPECT_EQ(neighbours[0].location_a, 1);
  EXPECT_EQ(neighbours[0].location_b, 2);
  EXPECT_EQ(neighbours[1].location_a, 2);
  EXPECT_EQ(neighbours[1].location_b, 3);
  EXPECT_EQ(store_->linksOfType(LinkType::kMerge).size(), 1u);
}

TEST_P(Records, HypothesesStateAndVocabularyImports) {
  Transaction tx = store_->begin();
  for (std::int64_t i = 1; i <= 2; ++i) {
    auto f = sampleFrame(i);
    f.id = i;
    store_->insertFrame(f);
  }
  store_->insertLocation({1, session_, 0, Tier::kWm, 1});
  store_->insertHypothesis({1, std::nullopt, 0.3, 0.0, false, "below T_loop", std::nullopt});
  store_->insertHypothesis({2, std::int64_t{1}, 0.8, 0.75, true, "", std::nullopt});
  tx.commit();
  const auto rejected = store_->hypothesis(1);
  ASSERT_TRUE(rejected);
  EXPECT_FALSE(rejected->best_location_id);
  EXPECT_DOUBLE_EQ(rejected->posterior, 0.3);
  EXPECT_FALSE(rejected->accepted);
  EXPECT_EQ(rejected->rejected_reason, "below T_loop");
  const auto accepted = store_->hypothesis(2);
  EXPECT_EQ(accepted->best_location_id, 1);
  EXPECT_DOUBLE_EQ(accepted->loop_probability, 0.75);
  EXPECT_TRUE(accepted->accepted);
  EXPECT_TRUE(accepted->rejected_reason.empty());
  EXPECT_FALSE(store_->hypothesis(3));

  EXPECT_FALSE(store_->getState("counters"));
  const std::vector<std::uint8_t> blob{0, 1, 2, 255, 0};
  store_->putState("counters", blob);
  store_->putState("next_location_id", std::string("17"));
  EXPECT_EQ(*store_->getState("counters"), blob);
  EXPECT_EQ(*store_->getStateText("next_location_id"), "17");
  store_->putState("next_location_id", std::string("18"));
  EXPECT_EQ(*store_->getStateText("next_location_id"), "18");
  store_->putState("empty", std::vector<std::uint8_t>{});
  EXPECT_TRUE(store_->getState("empty")->empty());

  store_->putPosterior({{-1, 0.25}, {1, 0.75}});
  store_->putPosterior({{0, 0.125}, {1, 0.875}});  // replaces, not appends
  EXPECT_EQ(store_->loadPosterior(),
            (std::vector<std::pair<std::int64_t, double>>{{0, 0.125}, {1, 0.875}}));

  VocabularyImportRecord import;
  import.session_id = session_;
  import.file = "vocab.pvoc";
  import.checksum = "sha256:abc";
  import.word_count = 10000;
  import.mode = VocabularyMode::kSeed;
  import.extractor = "surf";
  import.distance_unit = "squared";
  import.settings = {{"t_nd2", "0.08"}, { "quote\"key", "line\nbreak" }};
  const auto import_id = store_->recordVocabularyImport(import);
  import.mode = VocabularyMode::kFixed;
  import.imported_at = "2026-01-02T03:04:05.000Z";
  store_->recordVocabularyImport(import);
  const auto imports = store_->vocabularyImports();
  ASSERT_EQ(imports.size(), 2u);
  EXPECT_EQ(imports[0].id, import_id);
  EXPECT_EQ(imports[0].mode, VocabularyMode::kSeed);
  EXPECT_EQ(imports[0].word_count, 10000);
  EXPECT_EQ(imports[0].checksum, "sha256:abc");
  EXPECT_FALSE(imports[0].imported_at.empty());
  EXPECT_EQ(imports[1].mode, VocabularyMode::kFixed);
  EXPECT_EQ(imports[1].imported_at, "2026-01-02T03:04:05.000Z");
  EXPECT_EQ(imports[0].extractor, "surf");
  EXPECT_EQ(imports[0].distance_unit, "squared");
  EXPECT_EQ(imports[0].settings, import.settings) << "settings survive as a JSON object";

  // A word of an imported vocabulary has no creating frame.
  WordRecord word = WordRecord::fromFloats(1, std::nullopt, std::vector<float>(4, 1).data(), 4);
  word.vocabulary_import_id = import_id;
  word.source_frame = 4321;  // its frame in the map it was exported from
  WordRecord own = WordRecord::fromFloats(2, std::nullopt, std::vector<float>(4, 2).data(), 4);
  store_->insertWords({word, own});
  const auto loaded = store_->loadWords({1, 2});
  EXPECT_EQ(loaded[0].vocabulary_import_id, import_id);
  EXPECT_EQ(loaded[0].source_frame, 4321);
  EXPECT_FALSE(loaded[1].source_frame);
  EXPECT_EQ(store_->importedWordIds(), (std::vector<std::int64_t>{1}));
}

TEST_P(Records, ForeignKeysAreEnforced) {
  store_->insertFrame([&] {
    auto f = sampleFrame(0);
    f.id = 1;
    return f;
  }());
  store_->insertLocation({1, session_, 0, Tier::kWm, 1});
  if (GetParam() == "sqlite") {
    try {
      store_->insertWordRefs(1, {{12345, 0, 0, 1, 0, 1}});
      FAIL() << "a reference to an unknown word was stored";
    } catch (const StorageError& error) {
      EXPECT_EQ(error.code(), ErrorCode::kStorage);
      EXPECT_EQ(error.sqliteCode(), 787);  // SQLITE_CONSTRAINT_FOREIGNKEY
      EXPECT_NE(std::string(error.what()).find("FOREIGN KEY"), std::string::npos);
      EXPECT_NE(error.sql().find("INSERT INTO word_refs"), std::string::npos);
      EXPECT_NE(std::string(error.what()).find("INSERT INTO word_refs"), std::string::npos);
    }
  } else {
    // A server's word_refs has no keys since schema 16 (migrations/pg/0016 says why): what the
    // writer does not prove, check reports (PgMapStore.CheckFindsReferencesWhose...).
    store_->insertWordRefs(1, {{12345, 0, 0, 1, 0, 1}});
    EXPECT_EQ(store_->loadWordRefs(1).size(), 1u);
    store_->replaceWordRefs(1, {});
  }
  EXPECT_TRUE(store_->loadWordRefs(1).empty());

  // Deferred keys (to frames) are checked at commit; the whole frame then vanishes.
  Transaction tx = store_->begin();
  store_->insertLocation({2, session_, 0, Tier::kWm, 999});
  EXPECT_THROW(tx.commit(), StorageError);
  EXPECT_FALSE(store_->location(2));
  EXPECT_THROW(store_->insertLocation({3, 77, 0, Tier::kWm, std::nullopt}), StorageError);
}

TEST_P(Records, TransactionRollsBackUnlessCommitted) {
  {
    Transaction tx = store_->begin();
    store_->insertFrame(sampleFrame(0));
    try {
      store_->begin();
      ADD_FAILURE() << "nested transaction accepted";
    } catch (const Error& error) {
      EXPECT_EQ(error.code(), ErrorCode::kInternal);
    }
  }  // destroyed without commit
  EXPECT_EQ(store_->frameCount(), 0);
  {
    Transaction tx = store_->begin();
    store_->insertFrame(sampleFrame(0));
    tx.rollback();
    EXPECT_FALSE(tx.active());
  }
  EXPECT_EQ(store_->frameCount(), 0);
  testing::writeFrame(*store_, session_, 0);
  EXPECT_EQ(store_->frameCount(), 1);
}

TEST_P(Records, ReadOnlyOpenCannotWrite) {
  testing::writeFrame(*store_, session_, 0);
  const auto reader_owner = openMapStore(path_, OpenMode::kReadOnly);
  MapStore& reader = *reader_owner;
  EXPECT_TRUE(reader.readOnly());
  EXPECT_EQ(reader.frameCount(), 1);
  EXPECT_EQ(reader.loadWordRefs(1).size(), 4u);
  for (auto attempt : std::vector<std::function<void()>>{
           [&] { reader.begin(); },
           [&] { reader.insertLink(1, 2, LinkType::kNeighbour, std::nullopt); },
           [&] { reader.putState("k", std::string("v")); }}) {
    try {
      attempt();
      ADD_FAILURE() << "read-only map accepted a write";
    } catch (const Error& error) {
      EXPECT_EQ(error.code(), ErrorCode::kReadOnly) << error.what();
    }
  }
}

#ifdef PLACEDB_RECORDS_ON_PG
INSTANTIATE_TEST_SUITE_P(Postgresql, Records, ::testing::Values(std::string("postgresql")));
#else
INSTANTIATE_TEST_SUITE_P(Sqlite, Records, ::testing::Values(std::string("sqlite")));

namespace {

// Runs `body` in a child process as an unprivileged user (root ignores file permissions);
// returns the child's exit status, 0 meaning every check inside passed.
int runAsUnprivileged(const std::function<int()>& body) {
  const pid_t pid = fork();
  if (pid == 0) {
    if (geteuid() == 0 && (setgid(65534) != 0 || setuid(65534) != 0)) _exit(90);
    int status = 91;
    try {
      status = body();
    } catch (...) {
      status = 92;
    }
    _exit(status);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 93;
}

}  // namespace

TEST(ReadOnlyMedia, MapInReadOnlyFolderOpensForReadingOnly) {
  const auto dir = placedb::testing::scratchDir("ReadOnlyMedia");
  const auto folder = dir / "ro";
  std::filesystem::create_directories(folder);
  const std::string path = (folder / "map.db").string();
  {
    SqliteMapStore store(path, OpenMode::kReadWrite);
    const auto session = store.beginSession("src", {}, "test");
    for (int i = 0; i < 3; ++i) testing::writeFrame(store, session, i);
  }
  std::filesystem::remove(path + "-lock");
  ASSERT_FALSE(std::filesystem::exists(path + "-wal"));
  const std::string before = testing::readBytes(path);
  namespace fs = std::filesystem;
  fs::permissions(path, fs::perms::owner_read | fs::perms::group_read | fs::perms::others_read);
  fs::permissions(folder, fs::perms::owner_read | fs::perms::owner_exec | fs::perms::group_read |
                              fs::perms::group_exec | fs::perms::others_read |
                              fs::perms::others_exec);
  const int status = runAsUnprivileged([&] {
    {
      SqliteMapStore reader(path, OpenMode::kReadOnly);
      if (reader.frameCount() != 3 || reader.loadWordRefs(2).size() != 4) return 1;
      try {
        reader.insertLink(1, 2, LinkType::kNeighbour, 1.0);
        return 2;
      } catch (const Error& error) {
        if (error.code() != ErrorCode::kReadOnly) return 3;
      }
    }
    try {
      SqliteMapStore writer(path, OpenMode::kReadWrite);
      return 4;
    } catch (const Error& error) {
      if (error.code() != ErrorCode::kReadOnly) return 5;
    }
    return 0;
  });
  fs::permissions(folder, fs::perms::owner_all, fs::perm_options::add);
  fs::permissions(path, fs::perms::owner_write, fs::perm_options::add);
  EXPECT_EQ(status, 0) << "1 wrong content, 2 write accepted, 3/5 wrong error code, "
                          "4 read-write open accepted, 9x child setup";
  EXPECT_EQ(testing::readBytes(path), before);
}

#endif  // PLACEDB_RECORDS_ON_PG

}  // namespace
}  // namespace placedb::storage
