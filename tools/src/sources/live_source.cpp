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
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <opencv2/videoio/registry.hpp>
#include <regex>
#include <thread>

#include "features/image_conversion.h"
#include "interrupt.h"
#include "placedb/error.h"
#include "sources/mjpeg_stream.h"

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

// What the grabber last brought: an image FFmpeg decoded, or an MJPEG part's bytes (decoded when
// taken, so that parts dropped while the engine is busy cost nothing), or why there is none.
struct Arrival {
  cv::Mat image;
  std::string bytes;
  std::string problem;
};

// An image from a part's bytes, or why there is none; its header is judged before decoding.
cv::Mat decodePart(const std::string& bytes, std::string& problem) {
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  if (const auto size = readImageDimensions(data, bytes.size());
      size && !withinImageLimits(*size)) {
    problem = imageLimitProblem(*size);
    return cv::Mat();
  }
  cv::Mat image;
  try {
    image = cv::imdecode(
        cv::Mat(1, static_cast<int>(bytes.size()), CV_8U, const_cast<unsigned char*>(data)),
        cv::IMREAD_COLOR);
  } catch (const cv::Exception&) {
    image = cv::Mat();
  }
  if (image.empty())
    problem = fmt::format("a stream part of {} bytes that is no image", bytes.size());
  return image;
}

class LiveSource : public ImageSource {
 public:
  LiveSource(const std::string& source, double max_fps) : name_(source), max_fps_(max_fps) {
    quietVideoLibraries();
    std::smatch m;
    const std::string text = source;
    bool opened = false;
    if (std::regex_match(text, m, std::regex("camera:([0-9]+)"))) {
      opened = capture_.open(std::stoi(m[1]), cv::CAP_V4L2);
    } else if (text.rfind("/dev/", 0) == 0) {
      opened = capture_.open(text, cv::CAP_V4L2);
    } else {
      // An MJPEG stream over HTTP is read part by part (mjpeg_stream.h); anything else, and
      // every other stream, through FFmpeg, with bounded waits so that a stalled stream ends
      // instead of hanging Ctrl-C's close.
      mjpeg_ = MjpegHttpStream::open(text, kOpenTimeoutMs, kReadTimeoutMs, stop_);
      opened = mjpeg_ || capture_.open(text, cv::CAP_FFMPEG,
                                       {cv::CAP_PROP_OPEN_TIMEOUT_MSEC, kOpenTimeoutMs,
                                        cv::CAP_PROP_READ_TIMEOUT_MSEC, kReadTimeoutMs});
    }
    if (!opened)
      throw Error(ErrorCode::kIo,
                  fmt::format("cannot open live source {}: {}", source, whyNotOpened(text)));
    grabber_ = std::thread([this] { mjpeg_ ? grabParts() : grabFrames(); });
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
  std::string endProblem() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    return stalled_
               ? fmt::format("live source {} sent nothing for {} s", name_, kReadTimeoutMs / 1000)
               : std::string();
  }

  bool read(SourceFrame& frame) override {
    if (max_fps_ > 0 && taken_ > 0) {
      const auto due = last_taken_ + std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>(1.0 / max_fps_));
      while (Clock::now() < due && !interruptRequested())
        std::this_thread::sleep_for(
            std::min<Clock::duration>(due - Clock::now(), std::chrono::milliseconds(20)));
    }
    Arrival arrival;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      // Waits in short steps so that Ctrl-C ends a wait for a camera that stopped sending.
      while (!fresh_ && !ended_ && !interruptRequested())
        arrived_cv_.wait_for(lock, std::chrono::milliseconds(100));
      if (!fresh_) return false;
      frame.index = taken_++;
      arrival = std::move(latest_);
      latest_ = Arrival();
      fresh_ = false;
    }
    frame.path = framePathInSource(name_, "", frame.index);
    frame.problem = arrival.problem;
    frame.image = arrival.bytes.empty() ? arrival.image : decodePart(arrival.bytes, frame.problem);
    if (frame.image.empty() && frame.problem.empty()) frame.problem = "empty frame";
    frame.stamp_ns = std::nullopt;
    last_taken_ = Clock::now();
    return true;
  }

 private:
  void arrive(Arrival arrival) {
    std::lock_guard<std::mutex> lock(mutex_);
    latest_ = std::move(arrival);  // the previous one, if not taken, is dropped
    fresh_ = true;
    ++arrived_;
    arrived_cv_.notify_one();
  }
  void end(bool stalled) {
    std::lock_guard<std::mutex> lock(mutex_);
    ended_ = true;
    stalled_ = stalled && !stop_;
    arrived_cv_.notify_one();
  }

  void grabFrames() {
    cv::Mat image;
    while (!stop_) {
      const auto asked = Clock::now();
      if (!capture_.read(image) || image.empty()) {
        // FFmpeg gives up on a silent stream after its read timeout; an end comes sooner.
        const auto waited =
            std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - asked);
        return end(waited.count() >= kReadTimeoutMs - 500);
      }
      arrive({image.clone(), {}, {}});
    }
    end(false);
  }

  void grabParts() {
    while (!stop_) {
      StreamPart part;
      const StreamNext next = mjpeg_->next(part);
      if (next != StreamNext::kPart) return end(next == StreamNext::kStalled);
      arrive({cv::Mat(), std::move(part.bytes), std::move(part.problem)});
    }
    end(false);
  }

  std::string name_;
  double max_fps_;
  cv::VideoCapture capture_;
  std::unique_ptr<MjpegHttpStream> mjpeg_;
  std::thread grabber_;
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  std::condition_variable arrived_cv_;
  Arrival latest_;
  bool fresh_ = false, ended_ = false, stalled_ = false;
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
