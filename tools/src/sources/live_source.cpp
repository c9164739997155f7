#include "sources/live_source.h"

#include <fmt/format.h>

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <opencv2/videoio.hpp>
#include <opencv2/videoio/registry.hpp>
#include <regex>
#include <thread>

#include "interrupt.h"
#include "placedb/error.h"

namespace placedb::cli {
namespace {

using Clock = std::chrono::steady_clock;

// A network camera answers within seconds or is down; FFmpeg's own defaults wait far longer.
constexpr int kOpenTimeoutMs = 10000;
constexpr int kReadTimeoutMs = 5000;

// The V4L2 devices of this machine, for a message that names the cameras there are.
std::string videoDevices() {
  std::vector<std::string> found;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/dev", ec))
    if (std::regex_match(entry.path().filename().string(), std::regex("video[0-9]+")))
      found.push_back(entry.path().string());
  std::sort(found.begin(), found.end());
  std::string list;
  for (const auto& device : found) list += (list.empty() ? "" : " ") + device;
  return list.empty() ? "none" : list;
}

// What was tried and what stood in the way, for a source OpenCV would not open.
std::string whyNotOpened(const std::string& source) {
  std::smatch m;
  const bool camera = std::regex_match(source, m, std::regex("camera:([0-9]+)"));
  if (camera || source.rfind("/dev/", 0) == 0) {
    const std::string device = camera ? "/dev/video" + m[1].str() : source;
    if (!cv::videoio_registry::hasBackend(cv::CAP_V4L2))
      return "this OpenCV has no V4L2 backend to read cameras with";
    struct stat st {};
    if (::stat(device.c_str(), &st) != 0)
      return fmt::format("{} does not exist (V4L2 devices here: {})", device, videoDevices());
    if (!S_ISCHR(st.st_mode)) return fmt::format("{} is not a device", device);
    if (::access(device.c_str(), R_OK | W_OK) != 0)
      return fmt::format("{}: {} (is the user in its group, usually `video`?)", device,
                         std::strerror(errno));
    return fmt::format(
        "OpenCV's V4L2 backend could not open {} (another program may hold it, or it is not a "
        "capture device; V4L2 devices here: {})",
        device, videoDevices());
  }
  if (!cv::videoio_registry::hasBackend(cv::CAP_FFMPEG))
    return "this OpenCV has no FFmpeg backend to read streams with";
  return fmt::format(
      "FFmpeg could not open it, waiting up to {} s (the host unreachable or refusing, a wrong "
      "path, or not a video stream)",
      kOpenTimeoutMs / 1000);
}

class LiveSource : public ImageSource {
 public:
  LiveSource(const std::string& source, double max_fps) : name_(source), max_fps_(max_fps) {
    quietVideoLibraries();
    std::smatch m;
    const std::string text = source;
    bool opened = false;
    if (std::regex_match(text, m, std::regex("camera:([0-9]+)")))
      opened = capture_.open(std::stoi(m[1]), cv::CAP_V4L2);
    else if (text.rfind("/dev/", 0) == 0)
      opened = capture_.open(text, cv::CAP_V4L2);
    else  // bounded waits: a stalled stream ends the source instead of hanging Ctrl-C's close
      opened = capture_.open(text, cv::CAP_FFMPEG,
                             {cv::CAP_PROP_OPEN_TIMEOUT_MSEC, kOpenTimeoutMs,
                              cv::CAP_PROP_READ_TIMEOUT_MSEC, kReadTimeoutMs});
    if (!opened)
      throw Error(ErrorCode::kIo,
                  fmt::format("cannot open live source {}: {}", source, whyNotOpened(text)));
    grabber_ = std::thread([this] { grab(); });
  }
  ~LiveSource() override {
    stop_ = true;
    if (grabber_.joinable()) grabber_.join();
  }

  const std::string& canonicalPath() const override { return name_; }
  std::string kind() const override { return "live"; }
  std::optional<std::int64_t> size() const override { return std::nullopt; }
  void seek(std::int64_t) override {}  // a live source always starts a new session
  std::string digest() const override { return ""; }
  std::int64_t dropped() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    return arrived_ - taken_ - (fresh_ ? 1 : 0);
  }

  bool read(SourceFrame& frame) override {
    if (max_fps_ > 0 && taken_ > 0) {
      const auto due = last_taken_ + std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>(1.0 / max_fps_));
      while (Clock::now() < due && !interruptRequested())
        std::this_thread::sleep_for(
            std::min<Clock::duration>(due - Clock::now(), std::chrono::milliseconds(20)));
    }
    std::unique_lock<std::mutex> lock(mutex_);
    // Waits in short steps so that Ctrl-C ends a wait for a camera that stopped sending.
    while (!fresh_ && !ended_ && !interruptRequested())
      arrived_cv_.wait_for(lock, std::chrono::milliseconds(100));
    if (!fresh_) return false;
    frame.index = taken_++;
    frame.path = framePathInSource(name_, "", frame.index);
    frame.image = latest_;
    frame.problem = latest_.empty() ? "empty frame" : "";
    frame.stamp_ns = std::nullopt;
    latest_ = cv::Mat();
    fresh_ = false;
    last_taken_ = Clock::now();
    return true;
  }

 private:
  void grab() {
    cv::Mat image;
    while (!stop_) {
      if (!capture_.read(image) || image.empty()) break;
      std::lock_guard<std::mutex> lock(mutex_);
      latest_ = image.clone();  // the previous one, if not taken, is dropped
      fresh_ = true;
      ++arrived_;
      arrived_cv_.notify_one();
    }
    std::lock_guard<std::mutex> lock(mutex_);
    ended_ = true;
    arrived_cv_.notify_one();
  }

  std::string name_;
  double max_fps_;
  cv::VideoCapture capture_;
  std::thread grabber_;
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  std::condition_variable arrived_cv_;
  cv::Mat latest_;
  bool fresh_ = false, ended_ = false;
  std::int64_t arrived_ = 0, taken_ = 0;
  Clock::time_point last_taken_;
};

}  // namespace

bool isLiveSource(const std::string& source) {
  return std::regex_match(source, std::regex("camera:[0-9]+|/dev/video[0-9]+")) ||
         source.rfind("rtsp://", 0) == 0 || source.rfind("http://", 0) == 0 ||
         source.rfind("https://", 0) == 0;
}

std::unique_ptr<ImageSource> openLiveSource(const std::string& source, double max_fps) {
  return std::make_unique<LiveSource>(source, max_fps);
}

}  // namespace placedb::cli
