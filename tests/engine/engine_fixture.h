#pragma once
// Shared helpers of the engine tests: reading a data set's frame list and mapping frames.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "features/image_conversion.h"
#include "map/map_impl.h"
#include "placedb/map.h"
#include "placedb/storage/map_files.h"
#include "test_paths.h"

namespace placedb::testing {

struct Sequence {
  std::vector<std::string> paths;
  std::vector<cv::Mat> images;  // loaded once: several runs map the same frames
};

inline Sequence loadSequence(const std::filesystem::path& dir, std::size_t limit = 0) {
  Sequence s;
  std::ifstream in(dir / "frames.txt");
  std::string line;
  while (std::getline(in, line) && (limit == 0 || s.paths.size() < limit)) {
    if (line.empty() || line[0] == '#') continue;
    s.paths.push_back((dir / line).string());
    s.images.push_back(loadGreyImage(s.paths.back()));
  }
  return s;
}

// rtabmap_samples, read once per test binary; nullptr where the data set is absent (callers
// GTEST_SKIP() with datasetsDir() in the message).
inline const Sequence* rtabmapSamples() {
  static const std::optional<Sequence> cached = []() -> std::optional<Sequence> {
    auto dir = dataset("rtabmap_samples");
    if (dir.empty()) return std::nullopt;
    return loadSequence(dir);
  }();
  return cached ? &*cached : nullptr;
}

inline void removeMap(const std::filesystem::path& p) { storage::removeMap(p.string()); }

// A test over rtabmap_samples (skipped where the data set is absent) with a map path of its own
// in a fresh scratch folder.
class SamplesMapTest : public ::testing::Test {
 protected:
  void SetUp() override {
    seq_ = rtabmapSamples();
    if (!seq_) GTEST_SKIP() << "no rtabmap_samples under " << datasetsDir();
    path_ =
        scratchDir(::testing::UnitTest::GetInstance()->current_test_info()->name()) / "map.placedb";
  }
  const Sequence* seq_ = nullptr;
  std::filesystem::path path_;
};

inline MapImpl& impl(Map& map) { return dynamic_cast<MapImpl&>(map); }

// The first column of the first row of `sql` on the map, read-only; -1 when there is no row.
inline std::int64_t sqlCount(const std::filesystem::path& map, const std::string& sql) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open_v2(map.c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  EXPECT_EQ(sqlite3_prepare_v2(db, sql.c_str(), -1, &st, nullptr), SQLITE_OK) << sqlite3_errmsg(db);
  std::int64_t v = -1;
  if (sqlite3_step(st) == SQLITE_ROW) v = sqlite3_column_int64(st, 0);
  sqlite3_finalize(st);
  sqlite3_close(db);
  return v;
}

// Opens the map for frame `index` of a run that may have been stopped: a new session at the
// first frame, the last session resumed otherwise.
inline std::unique_ptr<Map> openForFrame(const std::filesystem::path& path, const Options& options,
                                         std::size_t index, const std::string& source) {
  auto map = Map::open(path.string(), options);
  if (index == 0)
    map->beginSession(source);
  else
    map->resumeSession(map->lastSession()->id);
  return map;
}

// What a run must reproduce exactly when resumed.
struct Outcome {
  std::int64_t location = 0, hypothesis = 0;
  FrameOutcome outcome = FrameOutcome::kNewLocation;
  double posterior = 0, score = 0;
  bool accepted = false;
  std::size_t wm = 0, stm = 0, vocabulary = 0, transferred = 0, retrieved = 0;
  std::size_t retrieved_by_search = 0;
};

inline Outcome outcomeOf(const FrameResult& r) {
  return {r.location_id,      r.hypothesis.location_id,
          r.outcome,          r.hypothesis.posterior,
          r.hypothesis.score, r.hypothesis.accepted,
          r.wm_size,          r.stm_size,
          r.vocabulary_size,  r.transferred,
          r.retrieved,        r.retrieved_by_search};
}

}  // namespace placedb::testing
