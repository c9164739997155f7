// ROS 2 bags in rosbag2's SQLite storage: a folder with metadata.yaml and NAME_0.db3, NAME_1.db3
// ... (split bags), or one .db3 file. Each file holds `topics (id, name, type,
// serialization_format, ...)` and `messages (id, topic_id, timestamp, data)`, data being the
// CDR-serialized message and timestamp the record time in ns. SQLite is already placedb's own
// storage, so the files are read with it directly, read-only.
#include <fmt/format.h>
#include <sqlite3.h>

#include <algorithm>
#include <filesystem>
#include <map>

#include "placedb/error.h"
#include "sources/bag_source.h"

namespace placedb::cli {
namespace {

namespace fs = std::filesystem;

class Ros2Bag : public BagReader {
 public:
  explicit Ros2Bag(const std::string& path) : path_(path) {
    std::error_code ec;
    if (fs::is_directory(path, ec)) {
      std::vector<std::string> other;
      for (const auto& entry : fs::directory_iterator(path, ec)) {
        const std::string ext = entry.path().extension().string();
        if (ext == ".db3") files_.push_back(entry.path().string());
        if (ext == ".mcap") other.push_back(entry.path().string());
      }
      std::sort(files_.begin(), files_.end(), naturalLess);
      if (files_.empty())
        throw Error(ErrorCode::kIo,
                    other.empty()
                        ? fmt::format("ROS 2 bag {} holds no .db3 file", path)
                        : fmt::format("ROS 2 bag {} is stored as MCAP, which placedb does not "
                                      "read: convert it to sqlite3 storage (`ros2 bag convert`)",
                                      path));
    } else {
      files_.push_back(path);
    }
    for (const auto& file : files_) {
      sqlite3* db = nullptr;
      const std::string uri = "file:" + file + "?mode=ro";
      if (sqlite3_open_v2(uri.c_str(), &db, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr) !=
          SQLITE_OK) {
        const std::string why = db ? sqlite3_errmsg(db) : "out of memory";
        sqlite3_close(db);
        throw Error(ErrorCode::kIo, fmt::format("cannot open ROS 2 bag file {}: {}", file, why));
      }
      dbs_.push_back(db);
      readTopics(db, file);
    }
  }
  ~Ros2Bag() override {
    sqlite3_finalize(messages_);
    for (sqlite3* db : dbs_) sqlite3_close(db);
  }

  std::vector<BagTopic> topics() const override {
    std::vector<BagTopic> out;
    for (const auto& [name, topic] : topics_) out.push_back(topic);
    return out;
  }
  WireFormat wireFormat() const override { return WireFormat::kCdr; }
  void select(const std::string& topic) override {
    topic_ = topic;
    seek(0);
  }
  std::pair<std::int64_t, std::int64_t> recordTimes() const override {
    std::int64_t first = 0, last = 0;
    bool any = false;
    for (std::size_t f = 0; f < dbs_.size(); ++f) {
      sqlite3_stmt* s = nullptr;
      if (sqlite3_prepare_v2(dbs_[f],
                             "SELECT min(m.timestamp), max(m.timestamp) FROM messages m JOIN "
                             "topics t ON t.id = m.topic_id WHERE t.name = ?1",
                             -1, &s, nullptr) != SQLITE_OK) {
        sqlite3_finalize(s);
        fail(dbs_[f], files_[f]);
      }
      sqlite3_bind_text(s, 1, topic_.c_str(), -1, SQLITE_TRANSIENT);
      if (sqlite3_step(s) == SQLITE_ROW && sqlite3_column_type(s, 0) != SQLITE_NULL) {
        const std::int64_t lo = sqlite3_column_int64(s, 0), hi = sqlite3_column_int64(s, 1);
        first = any ? std::min(first, lo) : lo;
        last = any ? std::max(last, hi) : hi;
        any = true;
      }
      sqlite3_finalize(s);
    }
    return {first, last};
  }
  void seek(std::int64_t index) override {
    file_ = 0;
    skip_ = index;
    open(0);
  }
  bool next(std::vector<std::uint8_t>& bytes, std::int64_t& time) override {
    while (messages_) {
      const int rc = sqlite3_step(messages_);
      if (rc == SQLITE_ROW) {
        if (skip_ > 0) {
          --skip_;
          continue;
        }
        time = sqlite3_column_int64(messages_, 0);
        const auto* data = static_cast<const std::uint8_t*>(sqlite3_column_blob(messages_, 1));
        bytes.assign(data, data + sqlite3_column_bytes(messages_, 1));
        return true;
      }
      if (rc != SQLITE_DONE) fail(dbs_[file_], files_[file_]);
      open(file_ + 1);
    }
    return false;
  }

 private:
  [[noreturn]] void fail(sqlite3* db, const std::string& file) const {
    throw Error(ErrorCode::kIo,
                fmt::format("cannot read ROS 2 bag file {}: {}", file, sqlite3_errmsg(db)));
  }

  void readTopics(sqlite3* db, const std::string& file) {
    sqlite3_stmt* s = nullptr;
    if (sqlite3_prepare_v2(db,
                           "SELECT t.name, t.type, t.serialization_format, "
                           "(SELECT count(*) FROM messages m WHERE m.topic_id = t.id) "
                           "FROM topics t",
                           -1, &s, nullptr) != SQLITE_OK) {
      sqlite3_finalize(s);
      throw Error(ErrorCode::kIo, fmt::format("{} is not a ROS 2 bag file (no topics and "
                                              "messages tables: {})",
                                              file, sqlite3_errmsg(db)));
    }
    while (sqlite3_step(s) == SQLITE_ROW) {
      const auto text = [s](int column) {
        const auto* t = sqlite3_column_text(s, column);
        return std::string(t ? reinterpret_cast<const char*>(t) : "");
      };
      BagTopic& topic = topics_[text(0)];
      topic.name = text(0);
      topic.type = text(1);
      topic.messages += sqlite3_column_int64(s, 3);
      if (text(2) != "cdr") topic.type += " (" + text(2) + ")";  // not CDR: not an image to us
    }
    sqlite3_finalize(s);
  }

  // Steps through file `file`'s messages of the topic, in record order.
  void open(std::size_t file) {
    sqlite3_finalize(messages_);
    messages_ = nullptr;
    file_ = file;
    if (file_ >= dbs_.size()) return;
    if (sqlite3_prepare_v2(dbs_[file_],
                           "SELECT m.timestamp, m.data FROM messages m JOIN topics t "
                           "ON t.id = m.topic_id WHERE t.name = ?1 ORDER BY m.timestamp, m.id",
                           -1, &messages_, nullptr) != SQLITE_OK)
      fail(dbs_[file_], files_[file_]);
    sqlite3_bind_text(messages_, 1, topic_.c_str(), -1, SQLITE_TRANSIENT);
  }

  std::string path_, topic_;
  std::vector<std::string> files_;
  std::vector<sqlite3*> dbs_;
  std::map<std::string, BagTopic> topics_;
  sqlite3_stmt* messages_ = nullptr;
  std::size_t file_ = 0;
  std::int64_t skip_ = 0;
};

}  // namespace

std::unique_ptr<BagReader> openRos2Bag(const std::string& path) {
  return std::make_unique<Ros2Bag>(path);
}

}  // namespace placedb::cli
