#include "sources/bag_source.h"

#include <fmt/format.h>

#include <filesystem>
#include <tuple>

#include "placedb/error.h"

namespace placedb::cli {
namespace {

namespace fs = std::filesystem;

std::string topicList(const std::vector<BagTopic>& topics, bool images_only) {
  std::string list;
  for (const auto& t : topics)
    if (!images_only || imageMessageKind(t.type))
      list += fmt::format("{}{} ({})", list.empty() ? "" : ", ", t.name, t.type);
  return list.empty() ? "none" : list;
}

class BagImageSource : public ImageSource {
 public:
  BagImageSource(std::string canonical, std::unique_ptr<BagReader> reader, BagTopic topic)
      : canonical_(std::move(canonical)),
        reader_(std::move(reader)),
        topic_(std::move(topic)),
        kind_(*imageMessageKind(topic_.type)) {
    reader_->select(topic_.name);
    count_ = topic_.messages;
    if (count_ == 0)  // as a list file without an image path: nothing to map
      throw Error(ErrorCode::kIo,
                  fmt::format("bag {} topic {} holds no message", canonical_, topic_.name));
    // The record times of the first and last messages make the digest (from the index); the
    // first message shows whether placedb can read the topic's encoding at all.
    std::tie(first_time_, last_time_) = reader_->recordTimes();
    std::int64_t time = 0;
    if (reader_->next(bytes_, time)) {
      const DecodedImage first =
          decodeImageMessage(bytes_.data(), bytes_.size(), kind_, reader_->wireFormat());
      if (first.problem.rfind("unknown image encoding", 0) == 0)
        throw Error(ErrorCode::kIo,
                    fmt::format("bag {} topic {}: {}", canonical_, topic_.name, first.problem));
    }
    reader_->seek(0);
  }

  const std::string& canonicalPath() const override { return canonical_; }
  std::string kind() const override { return "bag"; }
  std::optional<std::int64_t> size() const override { return count_; }
  void seek(std::int64_t index) override {
    next_ = std::max<std::int64_t>(0, index);
    reader_->seek(next_);
  }
  bool read(SourceFrame& frame) override {
    std::int64_t time = 0;
    if (!reader_->next(bytes_, time)) return false;
    const DecodedImage decoded =
        decodeImageMessage(bytes_.data(), bytes_.size(), kind_, reader_->wireFormat());
    frame.index = next_++;
    frame.path = framePathInSource(canonical_, topic_.name, frame.index);
    frame.image = decoded.image;
    frame.problem = decoded.problem;
    frame.stamp_ns = decoded.stamp_ns;
    return true;
  }
  // The topic, its message count and the record times of its first and last messages.
  std::string digest() const override {
    return fmt::format("bag:{}:{}:{}:{}", topic_.name, count_, first_time_, last_time_);
  }

 private:
  std::string canonical_;
  std::unique_ptr<BagReader> reader_;
  BagTopic topic_;
  ImageMessageKind kind_;
  std::int64_t count_ = 0, first_time_ = 0, last_time_ = 0, next_ = 0;
  std::vector<std::uint8_t> bytes_;
};

}  // namespace

bool isBag(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) return fs::exists(fs::path(path) / "metadata.yaml", ec);
  const std::string ext = fs::path(path).extension().string();
  return ext == ".bag" || ext == ".db3";
}

std::unique_ptr<ImageSource> openBag(const std::string& path, const std::string& topic) {
  std::unique_ptr<BagReader> reader =
      fs::path(path).extension() == ".bag" ? openRos1Bag(path) : openRos2Bag(path);
  const std::vector<BagTopic> topics = reader->topics();
  const BagTopic* chosen = nullptr;
  if (!topic.empty()) {
    for (const auto& t : topics)
      if (t.name == topic) chosen = &t;
    if (!chosen)
      throw Error(ErrorCode::kInvalidArgument,
                  fmt::format("bag {} has no topic {} (image topics: {})", path, topic,
                              topicList(topics, true)));
    if (!imageMessageKind(chosen->type))
      throw Error(ErrorCode::kInvalidArgument,
                  fmt::format("bag {} topic {} holds {}, not sensor_msgs/Image or "
                              "sensor_msgs/CompressedImage (image topics: {})",
                              path, topic, chosen->type, topicList(topics, true)));
  } else {
    for (const auto& t : topics) {
      if (!imageMessageKind(t.type)) continue;
      if (chosen)
        throw Error(ErrorCode::kInvalidArgument,
                    fmt::format("bag {} holds several image topics: choose one with --topic ({})",
                                path, topicList(topics, true)));
      chosen = &t;
    }
    if (!chosen)
      throw Error(ErrorCode::kIo, fmt::format("bag {} holds no image topic (topics: {})", path,
                                              topicList(topics, false)));
  }
  return std::make_unique<BagImageSource>(path, std::move(reader), *chosen);
}

}  // namespace placedb::cli
