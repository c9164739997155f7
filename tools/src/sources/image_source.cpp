#include "sources/image_source.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "features/image_conversion.h"
#include "placedb/error.h"
#include "sources/bag_source.h"
#include "sources/live_source.h"
#include "text_file.h"

namespace placedb::cli {
namespace fs = std::filesystem;
namespace {

std::string lowerExtension(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

std::string canonicalSource(const fs::path& path) {
  std::error_code ec;
  fs::path resolved = fs::canonical(path, ec);
  if (ec)
    throw Error(ErrorCode::kIo,
                fmt::format("cannot open source {}: {}", path.string(), ec.message()));
  return resolved.string();
}

// Both the folder and the list file are a list of image paths.
class PathListSource : public ImageSource {
 public:
  PathListSource(std::string canonical, std::string kind, std::vector<std::string> paths,
                 std::vector<std::string> skipped)
      : canonical_(std::move(canonical)),
        kind_(std::move(kind)),
        paths_(std::move(paths)),
        skipped_(std::move(skipped)) {}

  const std::string& canonicalPath() const override { return canonical_; }
  std::string kind() const override { return kind_; }
  std::optional<std::int64_t> size() const override {
    return static_cast<std::int64_t>(paths_.size());
  }
  void seek(std::int64_t index) override { next_ = std::max<std::int64_t>(0, index); }
  bool read(SourceFrame& frame) override {
    if (next_ >= static_cast<std::int64_t>(paths_.size())) return false;
    frame.index = next_;
    frame.path = paths_[static_cast<std::size_t>(next_)];
    frame.problem.clear();
    frame.image = readImageFile(frame.path, frame.problem);
    ++next_;
    return true;
  }
  std::vector<std::string> skippedFiles() const override { return skipped_; }
  std::string digest() const override {
    std::uint64_t hash = 14695981039346656037ull;  // FNV-1a 64
    for (const auto& path : paths_) {
      for (unsigned char c : path) hash = (hash ^ c) * 1099511628211ull;
      hash = (hash ^ 0u) * 1099511628211ull;  // the end of a path counts too
    }
    return fmt::format("paths:{}:{:016x}", paths_.size(), hash);
  }

 private:
  std::string canonical_, kind_;
  std::vector<std::string> paths_, skipped_;
  std::int64_t next_ = 0;
};

class VideoSource : public ImageSource {
 public:
  explicit VideoSource(std::string canonical) : canonical_(std::move(canonical)) {
    quietVideoLibraries();
    // FFmpeg only: the GStreamer fallback adds nothing for files and prints an assertion.
    if (!capture_.open(canonical_, cv::CAP_FFMPEG))
      throw Error(ErrorCode::kIo, fmt::format("cannot open video {}", canonical_));
    double count = capture_.get(cv::CAP_PROP_FRAME_COUNT);
    if (count > 0) count_ = static_cast<std::int64_t>(count);
  }
  const std::string& canonicalPath() const override { return canonical_; }
  std::string kind() const override { return "video"; }
  std::optional<std::int64_t> size() const override { return count_; }
  std::string digest() const override {
    std::error_code ec;
    const auto bytes = fs::file_size(canonical_, ec);
    return ec ? std::string() : fmt::format("bytes:{}", bytes);
  }
  void seek(std::int64_t index) override {
    // Seeking by timestamp is inexact in many containers: grab frame by frame instead.
    while (next_ < index && capture_.grab()) ++next_;
  }
  bool read(SourceFrame& frame) override {
    cv::Mat image;
    if (!capture_.read(image)) return false;
    frame.index = next_++;
    frame.path = framePathInSource(canonical_, "", frame.index);
    frame.problem = image.empty() ? "empty video frame" : "";
    frame.image = image;
    return true;
  }

 private:
  std::string canonical_;
  cv::VideoCapture capture_;
  std::optional<std::int64_t> count_;
  std::int64_t next_ = 0;
};

}  // namespace

// Ten lines for a broken MP4, also under --quiet.
void quietVideoLibraries() {
  static const bool done = [] {
    ::setenv("OPENCV_FFMPEG_LOGLEVEL", "-8", 0);  // AV_LOG_QUIET
    cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
    return true;
  }();
  (void)done;
}

std::string framePathInSource(const std::string& source, const std::string& topic,
                              std::int64_t index) {
  return topic.empty() ? fmt::format("{}#{}", source, index)
                       : fmt::format("{}#{}#{}", source, topic, index);
}

std::optional<FrameInSource> parseFramePathInSource(const std::string& path) {
  const auto first = path.find('#'), last = path.rfind('#');
  if (first == std::string::npos) return std::nullopt;
  FrameInSource frame;
  frame.source = path.substr(0, first);
  if (last != first) frame.topic = path.substr(first + 1, last - first - 1);
  char* end = nullptr;
  frame.index = std::strtoll(path.c_str() + last + 1, &end, 10);
  if (last + 1 == path.size() || *end != '\0' || frame.index < 0) return std::nullopt;
  return frame;
}

bool naturalLess(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    bool da = std::isdigit(static_cast<unsigned char>(a[i]));
    bool db = std::isdigit(static_cast<unsigned char>(b[j]));
    if (da && db) {
      std::size_t ei = i, ej = j;
      while (ei < a.size() && std::isdigit(static_cast<unsigned char>(a[ei]))) ++ei;
      while (ej < b.size() && std::isdigit(static_cast<unsigned char>(b[ej]))) ++ej;
      // Compare the runs as numbers without overflow: strip leading zeros, then length, digits.
      std::size_t zi = i, zj = j;
      while (zi + 1 < ei && a[zi] == '0') ++zi;
      while (zj + 1 < ej && b[zj] == '0') ++zj;
      if (ei - zi != ej - zj) return ei - zi < ej - zj;
      int cmp = a.compare(zi, ei - zi, b, zj, ej - zj);
      if (cmp != 0) return cmp < 0;
      // Equal values: fewer leading zeros first, so the order stays total.
      if (ei - i != ej - j) return ei - i < ej - j;
      i = ei;
      j = ej;
    } else {
      if (a[i] != b[j]) return static_cast<unsigned char>(a[i]) < static_cast<unsigned char>(b[j]);
      ++i;
      ++j;
    }
  }
  return a.size() - i < b.size() - j;
}

bool hasImageExtension(const fs::path& path) {
  // The formats OpenCV 4.6's imread decodes on Debian.
  static const char* const kImage[] = {".bmp",  ".dib", ".jpg", ".jpeg", ".jpe", ".jp2", ".png",
                                       ".webp", ".pbm", ".pgm", ".ppm",  ".pxm", ".pnm", ".pfm",
                                       ".sr",   ".ras", ".tif", ".tiff", ".exr", ".hdr", ".pic"};
  std::string ext = lowerExtension(path);
  return std::any_of(std::begin(kImage), std::end(kImage), [&](const char* e) { return ext == e; });
}

bool hasVideoExtension(const fs::path& path) {
  static const char* const kVideo[] = {".mp4",  ".avi", ".mkv", ".mov", ".webm", ".mpg",
                                       ".mpeg", ".m4v", ".wmv", ".flv", ".ogv",  ".mjpeg"};
  std::string ext = lowerExtension(path);
  return std::any_of(std::begin(kVideo), std::end(kVideo), [&](const char* e) { return ext == e; });
}

std::vector<std::string> readListFile(const fs::path& list_file) {
  const std::string content = readTextFile(list_file, "list file");
  if (content.find('\0') != std::string::npos)
    throw Error(ErrorCode::kIo,
                fmt::format("{} is neither an image folder, a list file nor a known video format",
                            list_file.string()));
  fs::path base = list_file.parent_path();
  std::vector<std::string> paths;
  std::size_t start = 0;
  while (start <= content.size()) {
    std::size_t end = content.find('\n', start);
    if (end == std::string::npos) end = content.size();
    std::string line = content.substr(start, end - start);
    start = end + 1;
    while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
    std::size_t first = 0;
    while (first < line.size() && std::isspace(static_cast<unsigned char>(line[first]))) ++first;
    line.erase(0, first);
    if (line.empty() || line[0] == '#') continue;
    fs::path entry(line);
    paths.push_back((entry.is_absolute() ? entry : base / entry).lexically_normal().string());
  }
  return paths;
}

void listImageFolder(const fs::path& folder, std::vector<std::string>& images,
                     std::vector<std::string>& skipped) {
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code type_ec;
    if (it->is_directory(type_ec)) continue;
    names.push_back(it->path().filename().string());
  }
  if (ec)
    throw Error(ErrorCode::kIo,
                fmt::format("cannot list folder {}: {}", folder.string(), ec.message()));
  std::sort(names.begin(), names.end(), naturalLess);
  for (const auto& name : names)
    (hasImageExtension(name) ? images : skipped).push_back((folder / name).string());
}

cv::Mat readImageFile(const std::string& path, std::string& problem) {
  // A folder opens like a file but throws on the first read.
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (fs::exists(status) && !fs::is_regular_file(status)) {
    problem = fs::is_directory(status) ? "a folder, not an image file" : "not a regular file";
    return {};
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    problem = "cannot open file";
    return {};
  }
  std::vector<unsigned char> bytes;
  try {
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  } catch (const std::ios_base::failure& e) {
    problem = fmt::format("cannot read: {}", e.what());
    return {};
  }
  if (bytes.empty()) {
    problem = "empty file";
    return {};
  }
  bool jpeg = bytes.size() >= 2 && bytes[0] == 0xFF && bytes[1] == 0xD8;
  if (jpeg) {
    // libjpeg fills a truncated image with grey and only warns; the missing EOI marker tells.
    std::size_t end = bytes.size();
    while (end > 2 && bytes[end - 1] == 0) --end;  // some writers pad with zeros
    if (end < 4 || bytes[end - 2] != 0xFF || bytes[end - 1] != 0xD9) {
      problem = "truncated JPEG (no end marker)";
      return {};
    }
  }
  // Before imdecode: decoding is what allocates the pixels.
  const std::optional<ImageDimensions> size = readImageDimensions(bytes.data(), bytes.size());
  if (size && !withinImageLimits(*size)) {
    problem = fmt::format("image is {}", imageLimitProblem(*size));
    return {};
  }
  cv::Mat image;
  try {
    image = cv::imdecode(bytes, cv::IMREAD_COLOR);
  } catch (const cv::Exception& e) {
    problem = fmt::format("cannot decode: {}", e.what());
    return {};
  }
  if (image.empty()) problem = "not a decodable image";
  return image;
}

std::unique_ptr<ImageSource> ImageSource::open(const std::string& source,
                                               const SourceOptions& options) {
  const bool live = isLiveSource(source);
  if (options.max_fps > 0 && !live)
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("--fps applies to cameras and streams; source {} is not one", source));
  if (live) {
    if (!options.topic.empty())
      throw Error(ErrorCode::kInvalidArgument,
                  fmt::format("--topic applies to ROS bags; source {} is a live one", source));
    return openLiveSource(source, options.max_fps);
  }
  fs::path path(source);
  std::error_code ec;
  if (!fs::exists(path, ec))
    throw Error(ErrorCode::kIo, fmt::format("source {} does not exist", source));
  std::string resolved = canonicalSource(path);
  if (isBag(resolved)) return openBag(resolved, options.topic);
  if (!options.topic.empty())
    throw Error(
        ErrorCode::kInvalidArgument,
        fmt::format("--topic {} applies to ROS bags; source {} is not one", options.topic, source));
  if (fs::is_directory(resolved, ec)) {
    std::vector<std::string> images, skipped;
    listImageFolder(resolved, images, skipped);
    if (images.empty())
      throw Error(ErrorCode::kIo, fmt::format("source folder {} holds no image", source));
    return std::make_unique<PathListSource>(resolved, "folder", std::move(images),
                                            std::move(skipped));
  }
  if (hasVideoExtension(resolved)) return std::make_unique<VideoSource>(resolved);
  if (hasImageExtension(resolved))
    throw Error(ErrorCode::kIo, fmt::format("source {} is a single image: give its folder or a "
                                            "list file",
                                            source));
  std::vector<std::string> paths = readListFile(resolved);
  if (paths.empty())
    throw Error(ErrorCode::kIo, fmt::format("list file {} holds no image path", source));
  return std::make_unique<PathListSource>(resolved, "list", std::move(paths),
                                          std::vector<std::string>{});
}

}  // namespace placedb::cli
