// Crashes, concurrent readers, competing writers and a full disk.
#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <thread>

#include <gtest/gtest.h>

#include "placedb/storage/sqlite_map_store.h"
#include "storage_test_util.h"
#include "test_paths.h"

namespace placedb::storage {
namespace {

std::string queryText(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  EXPECT_EQ(sqlite3_prepare_v2(db, sql.c_str(), -1, &stmt, nullptr), SQLITE_OK);
  std::string result;
  if (sqlite3_step(stmt) == SQLITE_ROW) {
    result = reinterpret_cast<const char*>(sqlite3_column_text(stmt, 0));
  }
  sqlite3_finalize(stmt);
  sqlite3_close(db);
  return result;
}

TEST(Crash, KilledWriterLosesOnlyTheOpenFrame) {
  const auto dir = placedb::testing::scratchDir("KilledWriter");
  const std::string path = (dir / "map.db").string();
  constexpr int kCommitted = 25;
  int ready[2];
  ASSERT_EQ(pipe(ready), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    close(ready[0]);
    try {
      SqliteMapStore store(path, OpenMode::kReadWrite);
      const auto session = store.beginSession("camera", {{"k", "v"}}, "test");
      for (int i = 0; i < kCommitted; ++i) testing::writeFrame(store, session, i, 20);
      // Frame kCommitted: written but never committed.
      Transaction tx = store.begin();
      FrameRecord frame;
      frame.id = kCommitted + 1;
      frame.session_id = session;
      frame.source_index = kCommitted;
      store.insertFrame(frame);
      store.insertLocation({kCommitted + 1, session, 0, Tier::kStm, frame.id});
      std::vector<float> values(8, 1.0f);
      store.insertWords({WordRecord::fromFloats(100000, frame.id, values.data(), 8)});
      const char signal_byte = 'x';
      if (write(ready[1], &signal_byte, 1) != 1) _exit(2);
      pause();
    } catch (...) {
      _exit(3);
    }
    _exit(0);
  }
  close(ready[1]);
  char received = 0;
  ASSERT_EQ(read(ready[0], &received, 1), 1) << "the writer died before signalling";
  close(ready[0]);
  ASSERT_EQ(kill(child, SIGKILL), 0);
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status));

  SqliteMapStore store(path, OpenMode::kReadWrite);  // the dead writer's lock went with it
  EXPECT_EQ(queryText(path, "PRAGMA integrity_check"), "ok");
  EXPECT_EQ(queryText(path, "SELECT count(*) FROM pragma_foreign_key_check"), "0");
  const auto session = store.lastSession();
  ASSERT_TRUE(session);
  EXPECT_FALSE(session->clean_close);
  EXPECT_FALSE(session->ended_at);
  EXPECT_EQ(store.frameCount(), kCommitted);
  EXPECT_EQ(store.lastFrameIndex(session->id), kCommitted - 1);
  EXPECT_FALSE(store.frame(kCommitted + 1));
  EXPECT_FALSE(store.location(kCommitted + 1));
  EXPECT_EQ(store.wordCount(), kCommitted * 20);
  EXPECT_TRUE(store.loadWords({100000}).empty());
  for (std::int64_t location = 1; location <= kCommitted; ++location) {
    ASSERT_EQ(store.loadWordRefs(location).size(), 20u) << "location " << location;
  }
  // The map carries on: the lost frame can be written again.
  testing::writeFrame(store, session->id, kCommitted, 20);
  EXPECT_EQ(store.frameCount(), kCommitted + 1);
}

TEST(Concurrency, ReaderSeesWholeFramesWhileWriterWrites) {
  const auto dir = placedb::testing::scratchDir("ReaderWhileWriting");
  const std::string path = (dir / "map.db").string();
  SqliteMapStore writer(path, OpenMode::kReadWrite);
  const auto session = writer.beginSession("camera", {}, "test");
  testing::writeFrame(writer, session, 0);
  constexpr int kFrames = 150;
  std::atomic<bool> done{false};
  std::atomic<int> reads{0};
  std::atomic<bool> reader_failed{false};
  std::string reader_error;  // written by the reader before reader_failed
  std::thread reader_thread([&] {
    try {
      SqliteMapStore reader(path, OpenMode::kReadOnly);
      std::int64_t previous = 0;
      while (!done.load()) {
        const std::int64_t frames = reader.frameCount();
        if (frames < previous) throw std::runtime_error("frame count went backwards");
        previous = frames;
        // A committed frame is always complete: its location has all four references.
        if (reader.loadWordRefs(frames).size() != 4) throw std::runtime_error("partial frame");
        ++reads;
      }
    } catch (const std::exception& error) {
      reader_error = error.what();
      reader_failed = true;
    }
  });
  for (int i = 1; i < kFrames; ++i) {
    testing::writeFrame(writer, session, i);
    // Every tenth frame, wait for the reader to get through a read, so the two interleave.
    const int seen = reads.load();
    const auto wait_until = std::chrono::steady_clock::now() + std::chrono::seconds(2);
    while (i % 10 == 0 && reads.load() == seen && !reader_failed.load() &&
           std::chrono::steady_clock::now() < wait_until) {
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
  }
  // Let the reader run at least a little after the last commit.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (reads.load() < 20 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  done = true;
  reader_thread.join();
  EXPECT_EQ(reader_error, "");
  EXPECT_GE(reads.load(), 20);
  EXPECT_EQ(writer.frameCount(), kFrames);
}

TEST(Checkpoint, TheLogIsCopiedBackWhileTheWriterGoesOnAndGoneAfterClose) {
  const auto dir = placedb::testing::scratchDir("Checkpoint");
  const std::string path = (dir / "map.db").string();
  const std::string wal = path + "-wal";
  constexpr std::uintmax_t kMiB = 1 << 20;
  {
    SqliteMapStore writer(path, OpenMode::kReadWrite);
    const std::uintmax_t before = std::filesystem::file_size(path);
    // 20 commits of ~1 MB each: 5,000 pages of log, past the 4,000 that call for a checkpoint.
    std::vector<std::uint8_t> blob;
    for (int i = 0; i < 20; ++i) {
      // Every byte new: SQLite rewrites only the pages of a value that changed.
      blob.assign(kMiB, static_cast<std::uint8_t>(i + 1));
      auto tx = writer.begin();
      writer.putState("blob." + std::to_string(i % 4), blob);
      tx.commit();
    }
    // Only a checkpoint writes the map file itself, and the writer's own comes at 32,000 pages:
    // the file grows by the blobs only when the thread copies the log back. How soon depends on
    // the machine's load, so the test waits for it.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    std::uintmax_t now = before;
    while (now < before + 3 * kMiB && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      now = std::filesystem::file_size(path);
    }
    EXPECT_GE(now, before + 3 * kMiB) << "the map file stayed at " << now << " bytes";
    EXPECT_EQ(writer.getState("blob.3")->size(), blob.size());
  }
  EXPECT_FALSE(std::filesystem::exists(wal)) << "the last connection removes the log";
  SqliteMapStore reader(path, OpenMode::kReadOnly);
  EXPECT_EQ(reader.getState("blob.0")->size(), std::size_t{1} << 20);
}

TEST(Concurrency, SecondPlacedbWriterIsRefused) {
  const auto dir = placedb::testing::scratchDir("SecondWriter");
  const std::string path = (dir / "map.db").string();
  // The other process is forked before this one opens the map: an open map runs a checkpoint
  // thread, and a child forked beside a thread can inherit a lock that thread held (the
  // allocator's, under the sanitizers) and hang. The child waits until the first writer is in.
  int ready[2];
  ASSERT_EQ(pipe(ready), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    close(ready[1]);
    char go = 0;
    if (read(ready[0], &go, 1) != 1) _exit(3);
    // Another process is refused the same way, while readers stay welcome.
    try {
      SqliteMapStore reader(path, OpenMode::kReadOnly);
      SqliteMapStore second(path, OpenMode::kReadWrite);
      _exit(1);
    } catch (const Error& error) {
      _exit(error.code() == ErrorCode::kMapBusy ? 0 : 2);
    }
  }
  close(ready[0]);
  {
    SqliteMapStore first(path, OpenMode::kReadWrite);
    try {
      SqliteMapStore second(path, OpenMode::kReadWrite);
      ADD_FAILURE() << "a second writer opened the map";
    } catch (const Error& error) {
      EXPECT_EQ(error.code(), ErrorCode::kMapBusy);
      EXPECT_NE(std::string(error.what()).find("another placedb writer"), std::string::npos);
    }
    const char go = 1;
    EXPECT_EQ(write(ready[1], &go, 1), 1);
    close(ready[1]);
    int status = 0;
    waitpid(child, &status, 0);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "child status " << status;
  }
}

TEST(Concurrency, ForeignWriteTransactionMakesBeginBusy) {
  const auto dir = placedb::testing::scratchDir("ForeignWriter");
  const std::string path = (dir / "map.db").string();
  OpenOptions options;
  options.busy_timeout_ms = 100;
  SqliteMapStore store(path, OpenMode::kReadWrite, options);
  const auto session = store.beginSession("camera", {}, "test");
  sqlite3* other = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &other), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(other, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr), SQLITE_OK);
  const auto started = std::chrono::steady_clock::now();
  try {
    testing::writeFrame(store, session, 0);
    ADD_FAILURE() << "wrote while another connection held the write lock";
  } catch (const StorageError& error) {
    EXPECT_EQ(error.code(), ErrorCode::kMapBusy);
    EXPECT_EQ(error.sqliteCode() & 0xff, SQLITE_BUSY);
    EXPECT_NE(std::string(error.what()).find("busy"), std::string::npos);
  }
  EXPECT_GE(std::chrono::steady_clock::now() - started, std::chrono::milliseconds(90));
  ASSERT_EQ(sqlite3_exec(other, "COMMIT", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(other);
  testing::writeFrame(store, session, 0);
  EXPECT_EQ(store.frameCount(), 1);
}

TEST(DiskFull, FullMapFailsTheFrameWithDiskFull) {
  const auto dir = placedb::testing::scratchDir("DiskFull");
  const std::string path = (dir / "map.db").string();
  OpenOptions options;
  options.max_page_count = 120;
  SqliteMapStore store(path, OpenMode::kReadWrite, options);
  const auto session = store.beginSession("camera", {}, "test");
  int written = 0;
  try {
    for (; written < 1000; ++written) testing::writeFrame(store, session, written, 50);
    FAIL() << "the page limit was never reached";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), ErrorCode::kDiskFull) << error.what();
  }
  EXPECT_GT(written, 0);
  EXPECT_EQ(store.frameCount(), written);  // the failed frame left nothing behind
  EXPECT_EQ(store.loadWordRefs(written).size(), 50u);
}

}  // namespace
}  // namespace placedb::storage
