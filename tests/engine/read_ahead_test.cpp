// Reading ahead of the frames (map/read_ahead.h): it reads the places asked and those linked to
// them on a connection of its own, never twice in a row, stops quietly on a map it cannot read,
// leaves every decision as it was and lets the writer's close remove the log.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <map>
#include <set>
#include <thread>

#include "engine_fixture.h"
#include "file_bytes.h"
#include "map/read_ahead.h"

namespace placedb::testing {
namespace {

class ReadAheadTest : public SamplesMapTest {
 protected:
  // Maps `frames` frames with a small working memory, so that places move to LTM and come back.
  std::vector<Outcome> mapFrames(std::size_t frames, const Options& options) {
    auto map = Map::open(path_.string(), options);
    map->beginSession("read ahead");
    std::vector<Outcome> out;
    for (std::size_t i = 0; i < frames; ++i)
      out.push_back(outcomeOf(map->process(seq_->images[i], i, seq_->paths[i])));
    return out;
  }
  static Options smallMemory(int read_ahead_links) {
    Options o;
    o.wm_max = 6;
    o.read_ahead_links = read_ahead_links;
    return o;
  }
  // The locations within `links` links of `from`, by the links table.
  std::set<std::int64_t> within(std::int64_t from, int links) {
    std::multimap<std::int64_t, std::int64_t> linked;
    sqlite3* db = nullptr;
    EXPECT_EQ(sqlite3_open_v2(path_.c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
    sqlite3_stmt* st = nullptr;
    EXPECT_EQ(sqlite3_prepare_v2(db, "SELECT location_a, location_b FROM links", -1, &st, nullptr),
              SQLITE_OK);
    while (sqlite3_step(st) == SQLITE_ROW) {
      linked.emplace(sqlite3_column_int64(st, 0), sqlite3_column_int64(st, 1));
      linked.emplace(sqlite3_column_int64(st, 1), sqlite3_column_int64(st, 0));
    }
    sqlite3_finalize(st);
    sqlite3_close(db);
    std::set<std::int64_t> seen{from}, edge{from};
    for (int depth = 0; depth < links; ++depth) {
      std::set<std::int64_t> next;
      for (std::int64_t id : edge)
        for (auto [it, end] = linked.equal_range(id); it != end; ++it)
          if (seen.insert(it->second).second) next.insert(it->second);
      edge = std::move(next);
    }
    return seen;
  }
};

TEST_F(ReadAheadTest, ReadsThePlacesWithinItsLinksOnce) {
  mapFrames(30, smallMemory(0));
  const std::string before = readBytes(path_);
  const std::int64_t middle = sqlCount(path_, "SELECT count(*) FROM locations") / 2;
  ASSERT_GT(middle, 3);
  const std::size_t expected = within(middle, 2).size();
  ASSERT_GE(expected, 3u) << "a place and its neighbours on both sides";

  ReadAheadSettings settings;
  settings.links = 2;
  {
    ReadAhead ahead(path_.string(), settings);
    ahead.ahead({middle});
    ahead.waitIdle();
    EXPECT_FALSE(ahead.stopped());
    EXPECT_EQ(ahead.placesRead(), expected);
    ahead.ahead({middle});  // read a moment ago: nothing to read again
    ahead.waitIdle();
    EXPECT_EQ(ahead.placesRead(), expected);
  }
  EXPECT_EQ(readBytes(path_), before) << "reading ahead only reads";
}

TEST_F(ReadAheadTest, ForgetsThePlacesItReadLongAgo) {
  // What it remembers is what it read lately, not every place a long session ever read.
  mapFrames(30, smallMemory(0));
  const std::int64_t locations = sqlCount(path_, "SELECT count(*) FROM locations");
  ASSERT_GE(locations, 4);
  ReadAheadSettings settings;
  settings.links = 0;
  settings.reread_after_s = 0.05;
  ReadAhead ahead(path_.string(), settings);
  ahead.ahead({1, 2});
  ahead.waitIdle();
  EXPECT_EQ(ahead.placesRemembered(), 2u);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ahead.ahead({3});
  ahead.waitIdle();
  EXPECT_EQ(ahead.placesRemembered(), 1u) << "places 1 and 2 were read over 0.05 s ago";
  ahead.ahead({1});  // forgotten, so read again
  ahead.waitIdle();
  EXPECT_EQ(ahead.placesRead(), 4u);
  EXPECT_FALSE(ahead.stopped());
}

TEST_F(ReadAheadTest, StopsQuietlyOnAMapItCannotRead) {
  ReadAhead ahead((path_.parent_path() / "absent.placedb").string(), ReadAheadSettings());
  ahead.ahead({1});
  ahead.waitIdle();
  EXPECT_TRUE(ahead.stopped());
  EXPECT_EQ(ahead.placesRead(), 0u);
  ahead.ahead({2});  // ignored once stopped
  ahead.waitIdle();
  EXPECT_FALSE(std::filesystem::exists(path_.parent_path() / "absent.placedb"));
}

TEST_F(ReadAheadTest, DecisionsDoNotDependOnIt) {
  const auto without = mapFrames(60, smallMemory(0));
  removeMap(path_);
  const auto with = mapFrames(60, smallMemory(1));
  ASSERT_EQ(with.size(), without.size());
  std::size_t retrieved = 0;
  for (std::size_t i = 0; i < with.size(); ++i) {
    retrieved += with[i].retrieved;
    EXPECT_EQ(with[i].location, without[i].location) << "frame " << i;
    EXPECT_EQ(with[i].hypothesis, without[i].hypothesis) << "frame " << i;
    EXPECT_EQ(with[i].accepted, without[i].accepted) << "frame " << i;
    EXPECT_EQ(with[i].posterior, without[i].posterior) << "frame " << i;
    EXPECT_EQ(with[i].wm, without[i].wm) << "frame " << i;
    EXPECT_EQ(with[i].retrieved, without[i].retrieved) << "frame " << i;
    EXPECT_EQ(with[i].transferred, without[i].transferred) << "frame " << i;
  }
  EXPECT_GT(retrieved, 0u) << "the run must bring places back from LTM to mean anything";
}

// The map file's open descriptors in this process: the writer's, and the read-ahead's own
// connection once it has started.
int descriptorsOf(const std::filesystem::path& file) {
  int count = 0;
  const auto target = std::filesystem::canonical(file);
  for (const auto& fd : std::filesystem::directory_iterator("/proc/self/fd")) {
    std::error_code error;
    const auto linked = std::filesystem::read_symlink(fd.path(), error);
    if (!error && linked == target) ++count;
  }
  return count;
}

TEST_F(ReadAheadTest, NothingInLongTermMemoryNothingRead) {
  Options unbounded;  // wm_max 0: every place stays in WM, none is ever brought back
  unbounded.read_ahead_links = 1;
  auto map = Map::open(path_.string(), unbounded);
  map->beginSession("read ahead");
  for (std::size_t i = 0; i < 30; ++i) map->process(seq_->images[i], i, seq_->paths[i]);
  EXPECT_EQ(descriptorsOf(path_), 1) << "only the writer's connection may hold the map";
  map.reset();
  // Once places are in LTM it does start (the counter-check of the above; the samples' first
  // frames merge into few locations, so the run is as long as the one that brings places back).
  removeMap(path_);
  map = Map::open(path_.string(), smallMemory(1));
  map->beginSession("read ahead");
  for (std::size_t i = 0; i < 60; ++i) map->process(seq_->images[i], i, seq_->paths[i]);
  // Its thread opens the connection on its first request, asynchronously.
  for (int wait = 0; wait < 100 && descriptorsOf(path_) < 2; ++wait)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_EQ(descriptorsOf(path_), 2);
}

TEST_F(ReadAheadTest, TheWritersCloseStillRemovesTheLog) {
  mapFrames(20, smallMemory(1));  // the map closes as it goes out of scope
  EXPECT_FALSE(std::filesystem::exists(storage::walFile(path_.string())))
      << "the read-ahead connection must be closed before the writer's";
}

}  // namespace
}  // namespace placedb::testing
