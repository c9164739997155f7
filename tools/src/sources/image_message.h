#pragma once
// sensor_msgs/Image and sensor_msgs/CompressedImage as a bag stores them: ROS 1's serialization
// (little-endian, no padding) or ROS 2's CDR (little-endian, each value aligned to its size from
// the end of the 4-byte encapsulation header). Only the fields placedb needs are read; every
// length is checked against the message's size, so a damaged message is a bad frame, not a
// crash.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

namespace placedb::cli {

enum class WireFormat { kRos1, kCdr };
enum class ImageMessageKind { kRaw, kCompressed };

// The kind for a message type name ("sensor_msgs/Image", "sensor_msgs/msg/CompressedImage"), or
// none when the type is not an image.
std::optional<ImageMessageKind> imageMessageKind(const std::string& type);

struct DecodedImage {
  cv::Mat image;                         // BGR or grey, 8 bits; empty when `problem` is set
  std::optional<std::int64_t> stamp_ns;  // header.stamp
  std::string frame_id;                  // header.frame_id
  std::string encoding;                  // a raw image's encoding, or a compressed one's format
  std::string problem;
};

DecodedImage decodeImageMessage(const std::uint8_t* data, std::size_t size, ImageMessageKind kind,
                                WireFormat format);

// The raw encodings placedb reads, for error messages.
const char* supportedEncodings();

}  // namespace placedb::cli
