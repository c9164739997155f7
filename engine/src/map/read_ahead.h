#pragma once
// Reads ahead of the frames. A revisit walks along a stretch of the map, and the next frame
// brings back from long-term memory the places most like it (the place-code search) and those
// linked to its hypothesis: it reads their signatures and word descriptors, and the check reads
// the keypoints of those the search found, loop candidates in that frame. When those rows have
// left the OS page cache (a map larger than RAM, or a kernel that pages out idle file pages),
// each retrieval waits for the disk inside the frame. The next frame's places are, most often,
// this frame's: those its search ranked just below the ones it brought back, and the places one
// link on from what it found. ReadAhead reads those rows on a thread and connection of its own,
// read-only and at a lower priority than the frame's threads, so that the next frame finds them
// in the cache. It only reads: no decision and no byte of the map depends on it, and any error
// it meets just stops it (the frames read the rows themselves, as without it).
//
// SQLite files only: a server map's pages live in the server's cache, not this machine's.
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

namespace placedb {

namespace storage {
class MapStore;
}

struct ReadAheadSettings {
  int links = 1;                 // the places this many links from those asked are read too
  std::size_t max_places = 64;   // at most this many places a request (a few ms of reading)
  double reread_after_s = 10.0;  // a place read this recently is still cached: not read again
};

class ReadAhead {
 public:
  // Opens its own read-only connection to `map_path` on the first request.
  ReadAhead(std::string map_path, ReadAheadSettings settings);
  ~ReadAhead();  // stops the thread; a request under way finishes its current read first
  ReadAhead(const ReadAhead&) = delete;
  ReadAhead& operator=(const ReadAhead&) = delete;

  // Reads `places`, nearest first, and those within settings.links links of them, soon. A
  // request not yet started is replaced: only the newest frame's places are worth reading.
  void ahead(std::vector<std::int64_t> places);
  // Waits until no request is pending or under way.
  void waitIdle();

  // What it has done so far: places read, places it remembers reading (those read within
  // settings.reread_after_s as of its last request), and whether an error stopped it.
  std::size_t placesRead() const;
  std::size_t placesRemembered() const;
  bool stopped() const;

 private:
  void run();
  struct Reached {
    std::int64_t id;
    int depth;        // links from the nearest place asked
    bool links_read;  // the walk read its links to go on from it
  };
  void read(const std::vector<std::int64_t>& places);
  std::vector<Reached> neighbourhood(const std::vector<std::int64_t>& places);

  const std::string path_;
  const ReadAheadSettings settings_;
  std::unique_ptr<storage::MapStore> reader_;  // the thread's own connection
  // When each place was last read, and the reads oldest first: forgetting the places read too
  // long ago pops the front of the queue, never walks every place remembered.
  std::unordered_map<std::int64_t, std::chrono::steady_clock::time_point> read_at_;
  std::deque<std::pair<std::chrono::steady_clock::time_point, std::int64_t>> reads_;

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::condition_variable idle_;
  std::optional<std::vector<std::int64_t>> pending_;
  bool busy_ = false;
  bool stopping_ = false;
  bool stopped_ = false;
  std::size_t places_read_ = 0;
  std::size_t places_remembered_ = 0;
  std::thread thread_;
};

}  // namespace placedb
