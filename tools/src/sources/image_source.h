#pragma once
// Where `placedb map` reads its frames from: an image folder, a list file, a video, a ROS bag
// (bag_source.h) or a camera or stream (live_source.h).
//
// - Folder: the files whose extension OpenCV's imread knows, in natural order (2.jpg before
//   10.jpg); other files are skipped and reported by skippedFiles().
// - List file: one image path a line, relative to the list file's folder; blank lines and
//   lines starting with '#' are ignored.
// - Video (by extension: .mp4 .avi .mkv .mov ...): read with cv::VideoCapture; the frame index
//   is the index in the video.
// Frame indices always count from the start of the source, also when reading starts later.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace placedb::cli {

struct SourceFrame {
  std::int64_t index = 0;
  std::string path;                      // the image file, or "<video>#<index>" for a video
  cv::Mat image;                         // empty when unreadable
  std::string problem;                   // why the image could not be read; empty when it was
  std::optional<std::int64_t> stamp_ns;  // a bag message's header.stamp, ns since the epoch
};

struct SourceOptions {
  std::string topic;   // a bag's image topic; empty: its only one (other sources: must be empty)
  double max_fps = 0;  // a live source's rate cap; 0: as fast as frames are processed
};

class ImageSource {
 public:
  // Throws placedb::Error(kIo) when the source is missing or cannot be opened, kInvalidArgument
  // when an option does not apply to it.
  static std::unique_ptr<ImageSource> open(const std::string& source,
                                           const SourceOptions& options = {});
  virtual ~ImageSource() = default;

  // Canonical absolute path: resuming compares it with the session's stored source.
  virtual const std::string& canonicalPath() const = 0;
  // "folder", "list", "video", "bag", "live" or "topic" (a ROS topic: ros/src/topic_source.h)
  virtual std::string kind() const = 0;
  // Number of frames, when known (a video's count is the container's estimate).
  virtual std::optional<std::int64_t> size() const = 0;
  // The next frame read() returns is `index`.
  virtual void seek(std::int64_t index) = 0;
  // False at the end of the source.
  virtual bool read(SourceFrame& frame) = 0;
  // Frames a live source dropped because they arrived while the engine was busy.
  virtual std::int64_t dropped() const { return 0; }
  // After read() returned false: why the source ended other than at its end (a live stream
  // that sent nothing for its read timeout), or "".
  virtual std::string endProblem() const { return ""; }
  // Folder entries that are not images, skipped.
  virtual std::vector<std::string> skippedFiles() const { return {}; }
  // What the source holds, short: "paths:N:HASH" (FNV-1a 64 of the image paths in order) for a
  // folder or list, "bytes:N" for a video. Stored with a session; a resume checks it.
  virtual std::string digest() const = 0;
};

// The path stored for a frame that is not a file of its own: "SOURCE#INDEX" for a video or a
// live source, "SOURCE#TOPIC#INDEX" for a bag's topic (`topic` empty: none).
std::string framePathInSource(const std::string& source, const std::string& topic,
                              std::int64_t index);
struct FrameInSource {
  std::string source, topic;
  std::int64_t index = 0;
};
// The parts of such a path; none for a path of another form (an image file's).
std::optional<FrameInSource> parseFramePathInSource(const std::string& path);

// FFmpeg and OpenCV print their own lines about a video or stream they cannot read; placedb's
// error names the source instead (OPENCV_FFMPEG_LOGLEVEL set by the user is kept).
void quietVideoLibraries();

// Natural order: digit runs compare as numbers ("img2" < "img10"), the rest byte by byte.
bool naturalLess(const std::string& a, const std::string& b);
bool hasImageExtension(const std::filesystem::path& path);
bool hasVideoExtension(const std::filesystem::path& path);
// The image paths of a list file, resolved against the list file's folder.
// Throws placedb::Error(kIo) when the file cannot be read or is binary.
std::vector<std::string> readListFile(const std::filesystem::path& list_file);
// Folder entries in natural order: images go to `images`, the rest to `skipped`.
void listImageFolder(const std::filesystem::path& folder, std::vector<std::string>& images,
                     std::vector<std::string>& skipped);
// Reads and decodes one image; on failure returns an empty Mat and sets `problem`.
// A JPEG without its end marker counts as truncated, even if a decoder would salvage part of it.
cv::Mat readImageFile(const std::string& path, std::string& problem);

}  // namespace placedb::cli
