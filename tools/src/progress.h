#pragma once
// Progress of `placedb map` on stderr: a redrawn bar with frames/s, ETA, the locations and loop
// closures this run added and the WM size on a terminal; on a pipe or file, one plain line every
// 5 s or 100 frames.
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>

namespace placedb::cli {

struct ProgressSample {
  std::int64_t source_index = 0;  // of the frame just processed
  std::int64_t locations = 0;     // locations created by this run
  std::int64_t wm_size = 0;
  std::int64_t loop_closures = 0;       // accepted by this run
  std::optional<std::int64_t> dropped;  // a live source's dropped frames
  // Frames in the whole source, when known: "frame 39 of 84" tells where a run that stops early
  // (--stop-after) or resumes stands in the source, which the run's own count does not.
  std::optional<std::int64_t> source_size;
};

class ProgressReporter {
 public:
  // `total`: frames this run will process, when known. `terminal`: redraw one line in place.
  ProgressReporter(std::optional<std::int64_t> total, bool terminal, std::FILE* out = stderr);
  // True when stderr is a terminal.
  static bool stderrIsTerminal();

  void update(const ProgressSample& sample);
  // Wipes the redrawn line so a warning starts on a clean line (no-op off a terminal).
  void clearLine();
  // Prints the final state (and ends the redrawn line).
  void finish();

  std::int64_t framesDone() const { return done_; }
  double framesPerSecond() const;
  // Formats the current state; exposed for the tests.
  std::string statusLine() const;

 private:
  using Clock = std::chrono::steady_clock;
  void emit();

  std::optional<std::int64_t> total_;
  bool terminal_;
  std::FILE* out_;
  Clock::time_point start_, last_emit_;
  std::int64_t done_ = 0, done_at_last_emit_ = 0;
  ProgressSample last_;
};

}  // namespace placedb::cli
