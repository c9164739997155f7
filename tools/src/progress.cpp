#include "progress.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>

namespace placedb::cli {
namespace {

constexpr auto kTerminalPeriod = std::chrono::milliseconds(200);
constexpr auto kPlainPeriod = std::chrono::seconds(5);
constexpr std::int64_t kPlainFrames = 100;
constexpr int kBarWidth = 24;

std::string duration(double seconds) {
  auto s = static_cast<std::int64_t>(seconds + 0.5);
  if (s >= 3600) return fmt::format("{}h{:02}m", s / 3600, (s % 3600) / 60);
  return fmt::format("{}m{:02}s", s / 60, s % 60);
}

}  // namespace

ProgressReporter::ProgressReporter(std::optional<std::int64_t> total, bool terminal, std::FILE* out)
    : total_(total), terminal_(terminal), out_(out), start_(Clock::now()), last_emit_(start_) {}

bool ProgressReporter::stderrIsTerminal() { return isatty(STDERR_FILENO) == 1; }

double ProgressReporter::framesPerSecond() const {
  double seconds = std::chrono::duration<double>(Clock::now() - start_).count();
  return seconds > 0 ? static_cast<double>(done_) / seconds : 0.0;
}

std::string ProgressReporter::statusLine() const {
  double fps = framesPerSecond();
  std::string head;
  if (total_ && *total_ > 0) {
    double fraction = std::min(1.0, static_cast<double>(done_) / static_cast<double>(*total_));
    std::string eta = fps > 0 ? duration(static_cast<double>(*total_ - done_) / fps) : "?";
    if (terminal_) {
      int filled = static_cast<int>(fraction * kBarWidth);
      head = fmt::format("[{}{}] ", std::string(filled, '#'), std::string(kBarWidth - filled, '.'));
    }
    head += fmt::format("{}/{} frames {:3.0f}%  ETA {}", done_, *total_, 100 * fraction, eta);
  } else {
    head = fmt::format("{} frames", done_);
  }
  return fmt::format("{}  {:.1f} frames/s  frame {}{}  new locations {}  WM {}  loops {}{}", head,
                     fps, last_.source_index,
                     last_.source_size ? fmt::format(" of {}", *last_.source_size) : "",
                     last_.locations, last_.wm_size, last_.loop_closures,
                     last_.dropped ? fmt::format("  dropped {}", *last_.dropped) : "");
}

void ProgressReporter::update(const ProgressSample& sample) {
  ++done_;
  last_ = sample;
  auto now = Clock::now();
  bool due = terminal_
                 ? now - last_emit_ >= kTerminalPeriod
                 : (now - last_emit_ >= kPlainPeriod || done_ - done_at_last_emit_ >= kPlainFrames);
  if (due) emit();
}

void ProgressReporter::emit() {
  last_emit_ = Clock::now();
  done_at_last_emit_ = done_;
  if (terminal_)
    std::fputs(fmt::format("\r{}\x1b[K", statusLine()).c_str(), out_);
  else
    std::fputs(fmt::format("placedb: {}\n", statusLine()).c_str(), out_);
  std::fflush(out_);
}

void ProgressReporter::clearLine() {
  if (terminal_) std::fputs("\r\x1b[K", out_);
}

void ProgressReporter::finish() {
  // Off a terminal the last periodic line may already be the final state.
  if (terminal_ || done_ != done_at_last_emit_) emit();
  if (terminal_) std::fputs("\n", out_);
  std::fflush(out_);
}

}  // namespace placedb::cli
