#include "sources/image_message.h"

#include <fmt/format.h>

#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace placedb::cli {
namespace {

struct Truncated : std::runtime_error {
  Truncated() : std::runtime_error("message shorter than its fields say") {}
};

// A bounds-checked reader of one serialized message.
class Cursor {
 public:
  Cursor(const std::uint8_t* data, std::size_t size, WireFormat format)
      : data_(data), size_(size), format_(format) {
    if (format_ == WireFormat::kCdr) {
      // Encapsulation: 0x00 0x01 is CDR little-endian, what ROS 2 writes on every common host.
      need(4);
      if (data_[0] != 0 || data_[1] != 1)
        throw std::runtime_error("not little-endian CDR (encapsulation " +
                                 std::to_string(data_[1]) + ")");
      origin_ = at_ = 4;
    }
  }

  std::uint32_t u32() {
    align(4);
    need(4);
    std::uint32_t v = std::uint32_t(data_[at_]) | std::uint32_t(data_[at_ + 1]) << 8 |
                      std::uint32_t(data_[at_ + 2]) << 16 | std::uint32_t(data_[at_ + 3]) << 24;
    at_ += 4;
    return v;
  }
  std::uint8_t u8() {
    need(1);
    return data_[at_++];
  }
  std::string string() {
    const std::uint32_t length = u32();
    need(length);
    std::string text(reinterpret_cast<const char*>(data_ + at_), length);
    at_ += length;
    // CDR counts the terminating NUL; ROS 1 does not store one.
    if (format_ == WireFormat::kCdr && !text.empty() && text.back() == '\0') text.pop_back();
    return text;
  }
  // A uint8[] field: its bytes in place.
  std::pair<const std::uint8_t*, std::size_t> bytes() {
    const std::uint32_t length = u32();
    need(length);
    const std::uint8_t* start = data_ + at_;
    at_ += length;
    return {start, length};
  }

  // std_msgs/Header: ROS 1 starts with a sequence number; the stamp is two 32-bit halves.
  std::int64_t header(std::string& frame_id) {
    if (format_ == WireFormat::kRos1) u32();  // seq
    const std::int64_t sec = format_ == WireFormat::kCdr ? std::int32_t(u32()) : u32();
    const std::int64_t nsec = u32();
    frame_id = string();
    return sec * 1000000000 + nsec;
  }

 private:
  void align(std::size_t n) {
    if (format_ == WireFormat::kCdr) at_ = origin_ + (at_ - origin_ + n - 1) / n * n;
  }
  void need(std::size_t n) const {
    if (at_ > size_ || size_ - at_ < n) throw Truncated();
  }

  const std::uint8_t* data_;
  std::size_t size_;
  WireFormat format_;
  std::size_t origin_ = 0, at_ = 0;
};

// A raw image's pixels as an 8-bit BGR or grey Mat (a copy: the message buffer is reused).
cv::Mat rawPixels(const std::string& encoding, int height, int width, std::uint32_t step,
                  bool big_endian, const std::uint8_t* data, std::size_t size,
                  std::string& problem) {
  int type = -1, code = -1;
  if (encoding == "mono8" || encoding == "8UC1") {
    type = CV_8UC1;
  } else if (encoding == "bgr8" || encoding == "8UC3") {
    type = CV_8UC3;
  } else if (encoding == "rgb8") {
    type = CV_8UC3;
    code = cv::COLOR_RGB2BGR;
  } else if (encoding == "bgra8") {
    type = CV_8UC4;
    code = cv::COLOR_BGRA2BGR;
  } else if (encoding == "rgba8") {
    type = CV_8UC4;
    code = cv::COLOR_RGBA2BGR;
  } else if (encoding == "mono16" || encoding == "16UC1") {
    type = CV_16UC1;
  } else {
    problem = fmt::format("unknown image encoding '{}' (placedb reads {})", encoding,
                          supportedEncodings());
    return {};
  }
  const std::size_t row = static_cast<std::size_t>(width) * CV_ELEM_SIZE(type);
  if (height <= 0 || width <= 0 || step < row ||
      size < static_cast<std::size_t>(step) * (height - 1) + row) {
    problem = fmt::format("{}x{} {} image with step {} does not fit its {} bytes of data", width,
                          height, encoding, step, size);
    return {};
  }
  cv::Mat view(height, width, type, const_cast<std::uint8_t*>(data), step);
  cv::Mat out;
  if (type == CV_16UC1) {
    cv::Mat wide = view.clone();
    if (big_endian)
      for (int y = 0; y < wide.rows; ++y)
        for (auto* p = wide.ptr<std::uint16_t>(y); p != wide.ptr<std::uint16_t>(y) + wide.cols; ++p)
          *p = static_cast<std::uint16_t>(*p >> 8 | *p << 8);
    wide.convertTo(out, CV_8U, 1.0 / 256);  // the high byte: what a viewer shows
  } else if (code >= 0) {
    cv::cvtColor(view, out, code);
  } else {
    out = view.clone();
  }
  return out;
}

}  // namespace

const char* supportedEncodings() {
  return "mono8, mono16, bgr8, rgb8, bgra8, rgba8, and compressed JPEG or PNG";
}

std::optional<ImageMessageKind> imageMessageKind(const std::string& type) {
  if (type == "sensor_msgs/Image" || type == "sensor_msgs/msg/Image") return ImageMessageKind::kRaw;
  if (type == "sensor_msgs/CompressedImage" || type == "sensor_msgs/msg/CompressedImage")
    return ImageMessageKind::kCompressed;
  return std::nullopt;
}

DecodedImage decodeImageMessage(const std::uint8_t* data, std::size_t size, ImageMessageKind kind,
                                WireFormat format) {
  DecodedImage out;
  try {
    Cursor in(data, size, format);
    out.stamp_ns = in.header(out.frame_id);
    if (kind == ImageMessageKind::kRaw) {
      const std::uint32_t height = in.u32(), width = in.u32();
      out.encoding = in.string();
      const bool big_endian = in.u8() != 0;
      const std::uint32_t step = in.u32();
      const auto [pixels, bytes] = in.bytes();
      if (height > 1 << 16 || width > 1 << 16) {
        out.problem = fmt::format("{}x{} image is larger than 65536 pixels a side", width, height);
        return out;
      }
      out.image = rawPixels(out.encoding, static_cast<int>(height), static_cast<int>(width), step,
                            big_endian, pixels, bytes, out.problem);
    } else {
      out.encoding = in.string();
      const auto [payload, bytes] = in.bytes();
      const cv::Mat buffer(1, static_cast<int>(bytes), CV_8U, const_cast<std::uint8_t*>(payload));
      out.image = bytes ? cv::imdecode(buffer, cv::IMREAD_COLOR) : cv::Mat();
      if (out.image.empty())
        out.problem = fmt::format("compressed image ({}) does not decode", out.encoding);
    }
  } catch (const std::exception& e) {
    out.image = cv::Mat();
    out.problem = e.what();
  }
  return out;
}

}  // namespace placedb::cli
