#pragma once
// A tiny deterministic parallel loop: tasks write disjoint outputs, so the result never depends
// on which thread ran which task or in what order.
//
// The helpers are threads kept for the process's life (parallel_for.cpp), not started per call:
// a frame runs four or more of these loops, and starting and joining a thread for each cost
// more than the shorter loops themselves. The caller takes tasks too and returns as soon as every
// task is done: a helper that a loaded machine has not run yet holds no task, so the caller never
// waits for it (joining one did: a frame's features took longer on two threads than on one).
//
// Not TBB (which OpenCV's Debian packages bring along): it would be a new dependency of the
// library and of everything that links it, for one loop, and its idle workers spin on a core
// that a loaded machine's other work needs.
#include <algorithm>

namespace placedb {

namespace detail {
// Runs run(context, i) for i in [0, count) on up to `threads` threads, the caller's included.
void parallelForTasks(int count, int threads, void (*run)(const void* context, int i),
                      const void* context);
}  // namespace detail

// Runs task(i) for i in [0, count) on up to `threads` threads (the caller's included).
// Tasks are handed out dynamically, so uneven tasks still balance.
template <typename Task>
void parallelFor(int count, int threads, const Task& task) {
  const int workers = std::max(1, std::min(threads, count));
  if (workers <= 1) {
    for (int i = 0; i < count; ++i) task(i);
    return;
  }
  detail::parallelForTasks(
      count, workers, [](const void* context, int i) { (*static_cast<const Task*>(context))(i); },
      &task);
}

}  // namespace placedb
