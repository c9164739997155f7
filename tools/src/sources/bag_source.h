#pragma once
// ROS bags as image sources: a ROS 1 bag (`run.bag`) and a ROS 2 bag (a folder with
// metadata.yaml and its .db3 files, or one .db3 file), one image topic of each.
//
// A bag backend lists the topics and hands over one topic's serialized messages in record order;
// BagImageSource chooses the topic, decodes each message (image_message.h) and keeps its
// header.stamp with the frame. Frame indices count the topic's messages from the first.
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "sources/image_message.h"
#include "sources/image_source.h"

namespace placedb::cli {

struct BagTopic {
  std::string name;
  std::string type;  // "sensor_msgs/Image", "sensor_msgs/msg/CompressedImage", ...
  std::int64_t messages = 0;
};

class BagReader {
 public:
  virtual ~BagReader() = default;
  virtual std::vector<BagTopic> topics() const = 0;
  virtual WireFormat wireFormat() const = 0;
  // Reads `topic` from its first message on; next() fills the message's bytes and record time.
  virtual void select(const std::string& topic) = 0;
  virtual void seek(std::int64_t index) = 0;
  virtual bool next(std::vector<std::uint8_t>& bytes, std::int64_t& record_time_ns) = 0;
  // The record times (ns) of the selected topic's first and last messages, from the bag's index:
  // no message is read.
  virtual std::pair<std::int64_t, std::int64_t> recordTimes() const = 0;
};

// True for what ImageSource::open hands to openBag: a .bag or .db3 file, or a folder holding
// metadata.yaml.
bool isBag(const std::string& canonical_path);

// Throws placedb::Error: kIo when the bag cannot be read, holds no image topic, or its first
// image has an encoding placedb cannot read; kInvalidArgument when `topic` is not an image topic
// of the bag, or none is given and the bag has several.
std::unique_ptr<ImageSource> openBag(const std::string& canonical_path, const std::string& topic);

// The backends (ros1_bag.cpp, ros2_bag.cpp).
std::unique_ptr<BagReader> openRos1Bag(const std::string& path);
std::unique_ptr<BagReader> openRos2Bag(const std::string& path);

}  // namespace placedb::cli
