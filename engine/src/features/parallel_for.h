#pragma once
// A tiny deterministic parallel loop: tasks write disjoint outputs, so the result never depends
// on which thread ran which task or in what order.
#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

namespace placedb {

// Runs task(i) for i in [0, count) on up to `threads` threads (the caller's included).
// Tasks are handed out dynamically, so uneven tasks still balance.
template <typename Task>
void parallelFor(int count, int threads, const Task& task) {
  const int workers = std::max(1, std::min(threads, count));
  if (workers <= 1) {
    for (int i = 0; i < count; ++i) task(i);
    return;
  }
  std::atomic<int> next{0};
  auto drain = [&] {
    for (int i = next.fetch_add(1); i < count; i = next.fetch_add(1)) task(i);
  };
  std::vector<std::thread> pool;
  pool.reserve(workers - 1);
  for (int w = 1; w < workers; ++w) pool.emplace_back(drain);
  drain();
  for (auto& thread : pool) thread.join();
}

}  // namespace placedb
