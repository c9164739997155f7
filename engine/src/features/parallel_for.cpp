#include "features/parallel_for.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>

namespace placedb::detail {
namespace {

// One call's tasks. Helpers hold it by shared_ptr, so one that wakes after the caller returned
// still finds it alive; it then claims no task (all are taken), so it never runs `run` late.
struct Job {
  int count = 0;
  void (*run)(const void*, int) = nullptr;
  const void* context = nullptr;
  std::atomic<int> next{0};      // the next task to claim
  std::atomic<int> done{0};      // tasks finished
  std::atomic<int> helpers{0};   // helpers this call may still take, beside its caller
  std::atomic<int> draining{0};  // threads inside drain()
  std::mutex mutex;
  std::condition_variable finished;
  std::exception_ptr failure;  // the first task's exception, for the caller to rethrow

  bool open() const { return next.load() < count; }
  // Runs tasks until none is left to claim. A task that throws ends the claiming, for everyone.
  void drain() {
    draining.fetch_add(1);
    for (int i = next.fetch_add(1); i < count; i = next.fetch_add(1)) {
      try {
        run(context, i);
      } catch (...) {
        next.store(count);
        std::lock_guard<std::mutex> lock(mutex);
        if (!failure) failure = std::current_exception();
        break;
      }
      if (done.fetch_add(1) + 1 == count) notify();
    }
    if (draining.fetch_sub(1) == 1) notify();
  }
  void notify() {
    std::lock_guard<std::mutex> lock(mutex);
    finished.notify_all();
  }
  // Whether the caller may return: every task done, or one failed and none is running.
  bool over() const { return done.load() == count || (failure && draining.load() == 0); }
};

class Helpers {
 public:
  static Helpers& instance() {
    // Never destroyed: helpers may still wait on the queue while static objects go at exit. A
    // forked child has none of its parent's threads (and maybe a mutex locked by one): it starts
    // its own.
    static Helpers* helpers = nullptr;
    static pid_t owner = 0;
    static std::mutex creating;
    std::lock_guard<std::mutex> lock(creating);
    if (!helpers || owner != getpid()) {
      helpers = new Helpers();
      owner = getpid();
    }
    return *helpers;
  }

  // Offers the job to up to `wanted` helpers, starting helpers until there are that many.
  void offer(const std::shared_ptr<Job>& job, int wanted) {
    job->helpers.store(wanted);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (; started_ < wanted; ++started_) std::thread([this] { serve(); }).detach();
      jobs_.push_back(job);
    }
    ready_.notify_all();
  }

  void withdraw(const std::shared_ptr<Job>& job) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = jobs_.begin(); it != jobs_.end(); ++it) {
      if (*it == job) {
        jobs_.erase(it);
        return;
      }
    }
  }

 private:
  // A job with tasks left that takes one more helper, marked as taken; null when none does.
  std::shared_ptr<Job> take() {
    for (const auto& job : jobs_) {
      if (!job->open()) continue;
      if (job->helpers.fetch_sub(1) > 0) return job;
      job->helpers.fetch_add(1);
    }
    return nullptr;
  }

  void serve() {
    for (;;) {
      std::shared_ptr<Job> job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        ready_.wait(lock, [&] { return (job = take()) != nullptr; });
      }
      job->drain();
    }
  }

  std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<std::shared_ptr<Job>> jobs_;
  int started_ = 0;
};

}  // namespace

void parallelForTasks(int count, int threads, void (*run)(const void* context, int i),
                      const void* context) {
  auto job = std::make_shared<Job>();
  job->count = count;
  job->run = run;
  job->context = context;
  Helpers& helpers = Helpers::instance();
  helpers.offer(job, threads - 1);
  job->drain();
  {
    std::unique_lock<std::mutex> lock(job->mutex);
    job->finished.wait(lock, [&] { return job->over(); });
  }
  helpers.withdraw(job);
  if (job->failure) std::rethrow_exception(job->failure);
}

}  // namespace placedb::detail
