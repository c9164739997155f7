#include "map/read_ahead.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <set>
#include <utility>

#include "map/state_keys.h"
#include "placedb/storage/map_store.h"

namespace placedb {

ReadAhead::ReadAhead(std::string map_path, ReadAheadSettings settings)
    : path_(std::move(map_path)), settings_(settings), thread_([this] { run(); }) {}

ReadAhead::~ReadAhead() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void ReadAhead::ahead(std::vector<std::int64_t> places) {
  if (places.empty()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopped_) return;
    pending_ = std::move(places);
  }
  wake_.notify_one();
}

void ReadAhead::waitIdle() {
  std::unique_lock<std::mutex> lock(mutex_);
  idle_.wait(lock, [this] { return stopped_ || (!pending_ && !busy_); });
}

std::size_t ReadAhead::placesRead() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return places_read_;
}

std::size_t ReadAhead::placesRemembered() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return places_remembered_;
}

bool ReadAhead::stopped() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stopped_;
}

void ReadAhead::run() {
  // The frame's own threads come first: this one only uses a core they leave idle. (Linux
  // gives each thread a nice value of its own; where it cannot be set, the default stays.)
  const auto self = static_cast<id_t>(::gettid());
  ::setpriority(PRIO_PROCESS, self, std::min(19, ::getpriority(PRIO_PROCESS, self) + 10));
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    wake_.wait(lock, [this] { return stopping_ || pending_; });
    if (stopping_) break;
    const std::vector<std::int64_t> places = std::move(*pending_);
    pending_.reset();
    busy_ = true;
    lock.unlock();
    bool failed = false;
    try {
      read(places);
    } catch (...) {
      // A map it cannot read (moved, locked, damaged): the frames read their rows themselves.
      failed = true;
    }
    lock.lock();
    busy_ = false;
    if (failed) {
      stopped_ = true;
      pending_.reset();
      reader_.reset();
    }
    idle_.notify_all();
    if (failed) break;
  }
  stopped_ = true;
  idle_.notify_all();
}

std::vector<ReadAhead::Reached> ReadAhead::neighbourhood(const std::vector<std::int64_t>& places) {
  // Breadth first over the stored links of every type (a revisit's stretch is joined to the
  // earlier visits by loop closures): the places asked, then one link on, and so on.
  std::vector<Reached> order;
  std::set<std::int64_t> seen;
  for (std::int64_t id : places) {
    if (order.size() >= settings_.max_places) return order;
    if (seen.insert(id).second) order.push_back({id, 0, false});
  }
  for (std::size_t next = 0; next < order.size() && order.size() < settings_.max_places; ++next) {
    if (order[next].depth >= settings_.links) break;  // breadth first: the rest are as deep
    const std::int64_t id = order[next].id;
    const int depth = order[next].depth;
    order[next].links_read = true;
    for (const storage::LinkRecord& l : reader_->links(id)) {
      const std::int64_t other = l.location_a == id ? l.location_b : l.location_a;
      if (!seen.insert(other).second) continue;
      order.push_back({other, depth + 1, false});
      if (order.size() >= settings_.max_places) break;
    }
  }
  return order;
}

void ReadAhead::read(const std::vector<std::int64_t>& places) {
  if (!reader_) reader_ = storage::openMapStore(path_, storage::OpenMode::kReadOnly);
  const auto now = std::chrono::steady_clock::now();
  const auto fresh = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(settings_.reread_after_s));
  storage::ReadSnapshot snapshot = reader_->readSnapshot();
  std::vector<std::int64_t> ids;
  for (const Reached& place : neighbourhood(places)) {
    auto at = read_at_.find(place.id);
    if (at != read_at_.end() && now - at->second < fresh) continue;
    read_at_[place.id] = now;
    reads_.emplace_back(now, place.id);
    ids.push_back(place.id);
    // Bringing a place back reads its links too; the walk above read those of the places it
    // went on from.
    if (!place.links_read) reader_->links(place.id);
  }
  // Forget the places read too long ago; one read again since keeps its newer time.
  while (!reads_.empty() && now - reads_.front().first >= fresh) {
    const auto [at, id] = reads_.front();
    reads_.pop_front();
    if (auto it = read_at_.find(id); it != read_at_.end() && it->second == at) read_at_.erase(it);
  }
  // The rest of what bringing a place back reads (MapImpl::bringBack: its word ids and its
  // words' descriptors), and what checking it as a loop candidate reads beside its word
  // references (MapImpl::loadKeypoints: its keypoints' descriptors, a blob of their own); the
  // results are dropped, the pages stay cached.
  if (!ids.empty()) {
    reader_->loadWordIds(ids);
    reader_->locationWordDescriptors(ids);
    for (std::int64_t id : ids) reader_->getState(keypointDescriptorsKey(id));
  }
  std::lock_guard<std::mutex> lock(mutex_);
  places_read_ += ids.size();
  places_remembered_ = read_at_.size();
}

}  // namespace placedb
