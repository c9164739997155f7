#pragma once
// Copies a writer's write-ahead log back into the map on a thread of its own, so that no frame
// waits for a checkpoint. SQLite's automatic checkpoint runs inside the COMMIT that crosses its
// 1000-page threshold: that frame copies the log into the map and syncs both files. Here the
// commit only signals; another connection of this process checkpoints PASSIVE, which never
// blocks the writer. The threshold is higher (4000 pages, 16 MB of log at 4 KB pages) because a
// checkpoint still syncs the log, and appends to a log being synced wait for it: fewer, larger
// checkpoints stall fewer frames (bench/quality/README.md has the figures). Should the thread
// fall far behind, the writer checkpoints itself, as SQLite would.
#include <sqlite3.h>

#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

namespace placedb::storage::detail {

class WalCheckpointer {
 public:
  // Installs itself as `writer`'s WAL hook (replacing SQLite's automatic checkpoint). `path` is
  // the map the background connection opens when the log first reaches `threshold_pages`.
  WalCheckpointer(sqlite3* writer, std::string path, int threshold_pages = 4000);
  // Stops the thread and closes its connection; the writer's own close then checkpoints the rest
  // and removes the log, as the last connection does.
  ~WalCheckpointer();
  WalCheckpointer(const WalCheckpointer&) = delete;
  WalCheckpointer& operator=(const WalCheckpointer&) = delete;

 private:
  static int onCommit(void* self, sqlite3* db, const char* schema, int pages);
  void run();

  sqlite3* writer_;
  std::string path_;
  int threshold_pages_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool requested_ = false;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace placedb::storage::detail
