// ROS 1 bags (format 2.0), read with the ROS project's own reader, rosbag_storage (Debian's
// librosbag-storage-dev): it handles the chunked, bz2- or lz4-compressed layout and the
// indexes. The messages are taken as serialized bytes and decoded by image_message.cpp, so
// placedb needs no generated message headers. Built only where the reader is installed
// (PLACEDB_WITH_ROS1_BAGS, set by tools/sources.cmake).
#include <fmt/format.h>

#include "placedb/error.h"
#include "sources/bag_source.h"

#ifdef PLACEDB_WITH_ROS1_BAGS
#include <rosbag/bag.h>
#include <rosbag/view.h>
#endif

namespace placedb::cli {

#ifdef PLACEDB_WITH_ROS1_BAGS
namespace {

class Ros1Bag : public BagReader {
 public:
  explicit Ros1Bag(const std::string& path) : path_(path) {
    try {
      bag_.open(path, rosbag::bagmode::Read);
      rosbag::View all(bag_);
      for (const rosbag::ConnectionInfo* c : all.getConnections()) {
        auto found = std::find_if(topics_.begin(), topics_.end(),
                                  [c](const BagTopic& t) { return t.name == c->topic; });
        if (found == topics_.end()) topics_.push_back({c->topic, c->datatype, 0});
      }
      for (BagTopic& t : topics_)
        t.messages = rosbag::View(bag_, rosbag::TopicQuery(t.name)).size();
    } catch (const rosbag::BagException& e) {
      throw Error(ErrorCode::kIo, fmt::format("cannot read ROS 1 bag {}: {}", path, e.what()));
    }
  }

  std::vector<BagTopic> topics() const override { return topics_; }
  WireFormat wireFormat() const override { return WireFormat::kRos1; }
  void select(const std::string& topic) override {
    view_ = std::make_unique<rosbag::View>(bag_, rosbag::TopicQuery(topic));
    seek(0);
  }
  std::pair<std::int64_t, std::int64_t> recordTimes() const override {
    return {static_cast<std::int64_t>(view_->getBeginTime().toNSec()),
            static_cast<std::int64_t>(view_->getEndTime().toNSec())};
  }
  void seek(std::int64_t index) override {
    at_ = view_->begin();
    for (std::int64_t i = 0; i < index && at_ != view_->end(); ++i) ++at_;
  }
  bool next(std::vector<std::uint8_t>& bytes, std::int64_t& time) override {
    try {
      if (at_ == view_->end()) return false;
      const rosbag::MessageInstance& m = *at_;
      bytes.resize(m.size());
      ros::serialization::OStream out(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
      m.write(out);
      time = static_cast<std::int64_t>(m.getTime().toNSec());
      ++at_;
      return true;
    } catch (const std::exception& e) {
      throw Error(ErrorCode::kIo, fmt::format("cannot read ROS 1 bag {}: {}", path_, e.what()));
    }
  }

 private:
  std::string path_;
  rosbag::Bag bag_;
  std::vector<BagTopic> topics_;
  std::unique_ptr<rosbag::View> view_;
  rosbag::View::iterator at_;
};

}  // namespace

std::unique_ptr<BagReader> openRos1Bag(const std::string& path) {
  return std::make_unique<Ros1Bag>(path);
}
#else
std::unique_ptr<BagReader> openRos1Bag(const std::string& path) {
  throw Error(ErrorCode::kIo, fmt::format("cannot read ROS 1 bag {}: this placedb was built "
                                          "without the ROS 1 bag reader (install "
                                          "librosbag-storage-dev, as scripts/install-deps.sh "
                                          "does, and rebuild)",
                                          path));
}
#endif

}  // namespace placedb::cli
