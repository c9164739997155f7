#pragma once
// A ROS image topic as the mapping loop's source (tools/src/commands/mapping_run.h). The
// subscriber's callback hands each message, still serialized, to a FrameMailbox and returns at
// once; the mapping loop takes frames from it and decodes them as a bag's
// (tools/src/sources/image_message.h), so a topic and a bag of the same messages give the same
// pixels and the same decisions.
//
// A robot's camera does not wait for the engine: with `drop` on, the mailbox keeps only the
// newest frame and counts every one it replaces, as a live camera source does. With it off,
// every frame is kept in order (a bag played faster than the engine maps).
//
// Nothing here depends on ROS: the node feeds it, the tests feed it directly.
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

#include "sources/image_message.h"
#include "sources/image_source.h"

namespace placedb::ros_node {

// One message as it arrived: its ROS 1 serialization and its kind.
struct SerializedImage {
  std::vector<std::uint8_t> bytes;
  cli::ImageMessageKind kind = cli::ImageMessageKind::kRaw;
};

class FrameMailbox {
 public:
  explicit FrameMailbox(bool drop) : drop_(drop) {}
  // From the subscriber's thread. With `drop` on, a frame still waiting is replaced (dropped).
  void put(SerializedImage message);
  // Waits for a frame, polling `stop` every 100 ms; false when stopped or closed and empty.
  bool take(SerializedImage& message, const std::function<bool()>& stop);
  // No more frames will come: take() returns what is left, then false.
  void close();
  std::int64_t dropped() const;
  std::int64_t waiting() const;

 private:
  const bool drop_;
  mutable std::mutex mutex_;
  std::condition_variable arrived_;
  std::deque<SerializedImage> frames_;
  std::int64_t dropped_ = 0;
  bool closed_ = false;
};

class TopicSource : public cli::ImageSource {
 public:
  // `name` is the session's source, stored in the map: resuming compares it. `stop` ends a wait
  // for a frame (Ctrl-C, a ROS shutdown).
  TopicSource(std::string name, bool drop, std::function<bool()> stop)
      : name_(std::move(name)), mailbox_(drop), stop_(std::move(stop)) {}

  FrameMailbox& mailbox() { return mailbox_; }
  // header.frame_id of the frame read() returned last.
  const std::string& frameId() const { return frame_id_; }

  const std::string& canonicalPath() const override { return name_; }
  std::string kind() const override { return "topic"; }
  std::optional<std::int64_t> size() const override { return std::nullopt; }
  // Frames are numbered on from `index` (a resumed session's next frame).
  void seek(std::int64_t index) override { next_index_ = index; }
  bool read(cli::SourceFrame& frame) override;
  std::int64_t dropped() const override { return mailbox_.dropped(); }
  std::string digest() const override { return ""; }

 private:
  std::string name_;
  FrameMailbox mailbox_;
  std::function<bool()> stop_;
  std::int64_t next_index_ = 0;
  std::string frame_id_;
};

}  // namespace placedb::ros_node
