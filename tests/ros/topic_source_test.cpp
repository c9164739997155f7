// The ROS node's topic source without ROS: the mailbox between the subscriber and the mapping
// loop (dropping and counting, or keeping every frame), and the frames it hands over.
#include <gtest/gtest.h>

#include <atomic>
#include <opencv2/imgcodecs.hpp>
#include <thread>

#include "topic_source.h"

namespace placedb::ros_node {
namespace {

void put32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

void putBytes(std::vector<std::uint8_t>& out, const void* data, std::size_t size) {
  put32(out, static_cast<std::uint32_t>(size));
  const auto* bytes = static_cast<const std::uint8_t*>(data);
  out.insert(out.end(), bytes, bytes + size);
}

// A sensor_msgs/CompressedImage in ROS 1's serialization, as a subscriber receives it.
SerializedImage compressedMessage(const cv::Mat& image, std::uint32_t sec, std::uint32_t nsec) {
  std::vector<std::uint8_t> png;
  cv::imencode(".png", image, png);
  SerializedImage m;
  m.kind = cli::ImageMessageKind::kCompressed;
  put32(m.bytes, 7);  // seq
  put32(m.bytes, sec);
  put32(m.bytes, nsec);
  putBytes(m.bytes, "camera", 6);
  putBytes(m.bytes, "png", 3);
  putBytes(m.bytes, png.data(), png.size());
  return m;
}

SerializedImage tagged(std::uint8_t tag) {
  SerializedImage m;
  m.bytes = {tag};
  return m;
}

TEST(RosFrameMailbox, DroppingKeepsTheNewestAndCountsTheRest) {
  FrameMailbox mailbox(true);
  for (std::uint8_t i = 0; i < 4; ++i) mailbox.put(tagged(i));
  EXPECT_EQ(mailbox.dropped(), 3);
  EXPECT_EQ(mailbox.waiting(), 1);
  SerializedImage m;
  ASSERT_TRUE(mailbox.take(m, [] { return false; }));
  EXPECT_EQ(m.bytes.front(), 3);
  mailbox.put(tagged(9));  // taken frames are not counted again
  EXPECT_EQ(mailbox.dropped(), 3);
}

TEST(RosFrameMailbox, KeepingHandsOverEveryFrameInOrder) {
  FrameMailbox mailbox(false);
  for (std::uint8_t i = 0; i < 5; ++i) mailbox.put(tagged(i));
  mailbox.close();
  mailbox.put(tagged(99));  // after close: ignored
  SerializedImage m;
  for (std::uint8_t i = 0; i < 5; ++i) {
    ASSERT_TRUE(mailbox.take(m, nullptr));
    EXPECT_EQ(m.bytes.front(), i);
  }
  EXPECT_FALSE(mailbox.take(m, nullptr));
  EXPECT_EQ(mailbox.dropped(), 0);
}

TEST(RosFrameMailbox, AWaitEndsWhenStopped) {
  FrameMailbox mailbox(true);
  std::atomic<bool> stop{false};
  std::thread stopper([&] { stop = true; });
  SerializedImage m;
  EXPECT_FALSE(mailbox.take(m, [&] { return stop.load(); }));
  stopper.join();
}

TEST(RosFrameMailbox, AWaitEndsWhenAFrameArrives) {
  FrameMailbox mailbox(true);
  std::thread subscriber([&] { mailbox.put(tagged(5)); });
  SerializedImage m;
  EXPECT_TRUE(mailbox.take(m, nullptr));
  EXPECT_EQ(m.bytes.front(), 5);
  subscriber.join();
}

TEST(RosTopicSource, DecodesFramesAndNumbersThemFromTheResumePoint) {
  TopicSource source("ros:/cam/image", false, nullptr);
  EXPECT_EQ(source.kind(), "topic");
  EXPECT_FALSE(source.size().has_value());
  cv::Mat image(48, 64, CV_8UC3);
  cv::randu(image, 0, 255);
  source.seek(10);
  source.mailbox().put(compressedMessage(image, 1700000000, 5000));
  SerializedImage broken = compressedMessage(image, 1700000001, 0);
  broken.bytes.resize(broken.bytes.size() - 40);  // cut: a bad frame, not a crash
  source.mailbox().put(broken);
  source.mailbox().close();

  cli::SourceFrame frame;
  ASSERT_TRUE(source.read(frame));
  EXPECT_EQ(frame.index, 10);
  EXPECT_EQ(frame.path, cli::framePathInSource("ros:/cam/image", "", 10));
  ASSERT_TRUE(frame.stamp_ns.has_value());
  EXPECT_EQ(*frame.stamp_ns, 1700000000LL * 1000000000 + 5000);
  EXPECT_EQ(source.frameId(), "camera");
  ASSERT_FALSE(frame.image.empty());
  EXPECT_EQ(cv::norm(frame.image, image, cv::NORM_INF), 0);

  ASSERT_TRUE(source.read(frame));
  EXPECT_EQ(frame.index, 11);
  EXPECT_TRUE(frame.image.empty());
  EXPECT_FALSE(frame.problem.empty());
  EXPECT_FALSE(source.read(frame));
}

}  // namespace
}  // namespace placedb::ros_node
