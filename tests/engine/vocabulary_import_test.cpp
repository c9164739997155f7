// Importing a vocabulary file into a new map: fixed vocabularies never grow and keep every word
// through transfers and resumes, seed vocabularies grow from them, refusals change nothing.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>

#include "engine_fixture.h"
#include "file_bytes.h"
#include "placedb/storage/sqlite_map_store.h"
#include "vocabulary/vocabulary_file.h"

namespace placedb::testing {
namespace {

class VocabularyImport : public ::testing::Test {
 protected:
  void SetUp() override {
    seq_ = rtabmapSamples();
    if (!seq_) GTEST_SKIP() << "no rtabmap_samples under " << datasetsDir();
    dir_ = scratchDir(std::string("VocabularyImport_") +
                      ::testing::UnitTest::GetInstance()->current_test_info()->name());
    // A vocabulary learnt on the first half of the sequence, written as a vocabulary file.
    const auto source = dir_ / "source.placedb";
    {
      auto map = Map::open(source.string(), Options());
      map->beginSession("first half");
      for (std::size_t i = 0; i < 40; ++i) map->process(seq_->images[i], i, seq_->paths[i]);
    }
    storage::SqliteMapStore store(source.string(), storage::OpenMode::kReadOnly);
    std::vector<std::int64_t> ids;
    for (std::int64_t id = 0; id <= store.maxWordId().value_or(-1); ++id) ids.push_back(id);
    vocab::VocabularyData data;
    data.extractor = "surf";
    data.dim = 64;
    data.settings = Options().toSettings();
    const auto words = store.loadWords(ids);
    data.descriptors.create(static_cast<int>(words.size()), 64, CV_32F);
    for (std::size_t i = 0; i < words.size(); ++i) {
      data.ids.push_back(words[i].id);
      data.created_frames.push_back(words[i].created_frame.value_or(-1));
      const auto values = words[i].floats();
      std::copy(values.begin(), values.end(), data.descriptors.ptr<float>(static_cast<int>(i)));
    }
    file_ = dir_ / "words.pvoc";
    vocab::writeVocabularyFile(file_, data);
    word_count_ = words.size();
    ASSERT_GT(word_count_, 1000u);
  }

  const Sequence* seq_ = nullptr;
  std::filesystem::path dir_, file_;
  std::size_t word_count_ = 0;
};

TEST_F(VocabularyImport, FixedVocabularyNeverGrowsKeepsItsWordsAndResumes) {
  Options options;
  options.wm_max = 10;  // transfers every frame once WM is full: words must not leave
  const auto path = dir_ / "fixed.placedb";
  int accepted = 0;
  {
    auto map = Map::open(path.string(), options);
    EXPECT_EQ(map->importVocabulary(file_.string(), false, VocabularyMode::kFixed), word_count_);
    map->beginSession("whole sequence");
    for (std::size_t i = 0; i < 60; ++i) {
      const auto r = map->process(seq_->images[i], i, seq_->paths[i]);
      ASSERT_EQ(r.words_created, 0u) << "frame " << i;
      ASSERT_EQ(r.vocabulary_size, word_count_) << "frame " << i;
      accepted += r.hypothesis.accepted;
      ASSERT_EQ(impl(*map).checkConsistency(), "") << "frame " << i;
    }
  }
  auto map = Map::open(path.string(), options);
  map->resumeSession(map->lastSession()->id);
  EXPECT_EQ(impl(*map).checkConsistency(), "");
  for (std::size_t i = 60; i < seq_->images.size(); ++i) {
    const auto r = map->process(seq_->images[i], i, seq_->paths[i]);
    ASSERT_EQ(r.words_created, 0u) << "frame " << i;
    ASSERT_EQ(r.vocabulary_size, word_count_) << "frame " << i;
    accepted += r.hypothesis.accepted;
  }
  EXPECT_GT(accepted, 5) << "an imported vocabulary still closes the sequence's loops";
}

TEST_F(VocabularyImport, SeedVocabularyGrowsFromTheImportedWords) {
  const auto path = dir_ / "seed.placedb";
  auto map = Map::open(path.string(), Options());
  map->importVocabulary(file_.string(), false, VocabularyMode::kSeed);
  map->beginSession("second half");
  std::size_t created = 0, last_size = 0;
  for (std::size_t i = 40; i < seq_->images.size(); ++i) {
    const auto r = map->process(seq_->images[i], i, seq_->paths[i]);
    // A merged frame's new words leave again with it (SPEC §5); a new location keeps them.
    if (r.outcome == FrameOutcome::kNewLocation) created += r.words_created;
    last_size = r.vocabulary_size;
  }
  EXPECT_GT(created, 0u);
  EXPECT_EQ(last_size, word_count_ + created) << "nothing else leaves an unbounded memory";
  EXPECT_EQ(impl(*map).checkConsistency(), "");
}

TEST_F(VocabularyImport, RefusalsLeaveTheMapAsItWas) {
  auto code = [](auto&& f) {
    try {
      f();
    } catch (const Error& e) {
      return static_cast<int>(e.code());
    }
    return 0;
  };
  // A map that already has frames.
  const auto used = dir_ / "used.placedb";
  {
    auto map = Map::open(used.string(), Options());
    map->beginSession("one frame");
    map->process(seq_->images[0], 0, seq_->paths[0]);
  }
  const std::string before = readBytes(used);
  EXPECT_EQ(code([&] {
              auto map = Map::open(used.string(), Options());
              map->importVocabulary(file_.string(), false, VocabularyMode::kSeed);
            }),
            static_cast<int>(ErrorCode::kInvalidArgument));
  EXPECT_EQ(readBytes(used), before);

  // A truncated file, and words of another extractor of the same dimension.
  const auto truncated = dir_ / "truncated.pvoc";
  {
    const std::string bytes = readBytes(file_);
    std::ofstream(truncated, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  Options kaze;
  kaze.extractor = Extractor::kKaze;
  const std::vector<std::pair<std::filesystem::path, Options>> refused = {{truncated, Options()},
                                                                          {file_, kaze}};
  for (const auto& [file, options] : refused) {
    const std::string extractor = toString(options.extractor);
    SCOPED_TRACE(file.filename().string() + " with extractor " + extractor);
    const auto path = dir_ / ("new_" + extractor + ".placedb");
    auto map = Map::open(path.string(), options);
    EXPECT_EQ(code([&] { map->importVocabulary(file.string(), false, VocabularyMode::kFixed); }),
              static_cast<int>(ErrorCode::kVocabularyRefused));
    storage::SqliteMapStore store(path.string(), storage::OpenMode::kReadOnly);
    EXPECT_EQ(store.wordCount(), 0);
    EXPECT_TRUE(store.vocabularyImports().empty());
    // Nothing half-done in RAM either: the map still maps from scratch.
    map->beginSession("after a refusal");
    EXPECT_GT(map->process(seq_->images[0], 0, seq_->paths[0]).words_created, 0u);
  }
}

}  // namespace
}  // namespace placedb::testing
