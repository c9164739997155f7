#include "topic_source.h"

#include <chrono>

namespace placedb::ros_node {

void FrameMailbox::put(SerializedImage message) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (closed_) return;
  if (drop_ && !frames_.empty()) {
    dropped_ += static_cast<std::int64_t>(frames_.size());
    frames_.clear();
  }
  frames_.push_back(std::move(message));
  arrived_.notify_one();
}

bool FrameMailbox::take(SerializedImage& message, const std::function<bool()>& stop) {
  std::unique_lock<std::mutex> lock(mutex_);
  // Short waits, so that Ctrl-C ends a wait for a camera that stopped sending.
  while (frames_.empty() && !closed_ && !(stop && stop()))
    arrived_.wait_for(lock, std::chrono::milliseconds(100));
  if (frames_.empty()) return false;
  message = std::move(frames_.front());
  frames_.pop_front();
  return true;
}

void FrameMailbox::close() {
  std::lock_guard<std::mutex> lock(mutex_);
  closed_ = true;
  arrived_.notify_all();
}

std::int64_t FrameMailbox::dropped() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return dropped_;
}

std::int64_t FrameMailbox::waiting() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return static_cast<std::int64_t>(frames_.size());
}

bool TopicSource::read(cli::SourceFrame& frame) {
  if (stop_ && stop_()) return false;
  SerializedImage message;
  if (!mailbox_.take(message, stop_)) return false;
  cli::DecodedImage decoded = cli::decodeImageMessage(message.bytes.data(), message.bytes.size(),
                                                      message.kind, cli::WireFormat::kRos1);
  frame.index = next_index_++;
  frame.path = cli::framePathInSource(name_, "", frame.index);
  frame.image = std::move(decoded.image);
  frame.problem = std::move(decoded.problem);
  frame.stamp_ns = decoded.stamp_ns;
  frame_id_ = std::move(decoded.frame_id);
  return true;
}

}  // namespace placedb::ros_node
