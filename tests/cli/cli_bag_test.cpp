// ROS bags as sources: a ROS 1 bag written by the ROS project's own Python writer and a ROS 2
// bag laid out as rosbag2's sqlite3 storage writes it map with the same decisions as the list
// file of the same images, keep each message's stamp, resume, and refuse what they cannot read
// with one line that creates nothing.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <regex>

#include "cli_map_edits.h"
#include "cli_scratch.h"
#include "frame_log.h"

namespace placedb::testing {
namespace {

constexpr std::int64_t kFirstStampSec = 1700000000;

std::vector<std::string> imagePaths(const fs::path& seq) {
  std::vector<std::string> paths;
  std::ifstream list(seq / "frames.txt");
  for (std::string line; std::getline(list, line);)
    if (!line.empty()) paths.push_back((seq / line).string());
  return paths;
}

// What a camera driver would publish for each image: the pixels in `encoding`, or the
// compressed file when `encoding` is png.
std::string payload(const std::string& path, const std::string& encoding, int& width, int& height,
                    int& step) {
  cv::Mat bgr = cv::imread(path, cv::IMREAD_COLOR);
  width = bgr.cols;
  height = bgr.rows;
  if (encoding == "png") {
    std::vector<std::uint8_t> png;
    cv::imencode(".png", bgr, png);
    return std::string(png.begin(), png.end());
  }
  cv::Mat out;
  if (encoding == "bgr8") out = bgr;
  if (encoding == "rgb8") cv::cvtColor(bgr, out, cv::COLOR_BGR2RGB);
  if (encoding == "mono8") cv::cvtColor(bgr, out, cv::COLOR_BGR2GRAY);
  if (encoding == "mono16") {
    cv::Mat grey;
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
    grey.convertTo(out, CV_16U, 256);  // little-endian on the hosts placedb runs on
  }
  if (encoding == "yuv422") out = bgr;  // bytes of the right size, an encoding placedb refuses
  out = out.clone();
  step = static_cast<int>(out.step);
  return std::string(reinterpret_cast<const char*>(out.data), out.total() * out.elemSize());
}

fs::path writeRos1Bag(const fs::path& seq, const fs::path& dir, const std::string& topic,
                      const std::string& encoding) {
  const fs::path frames = dir / ("frames_" + encoding);
  fs::create_directories(frames);
  const bool compressed = encoding == "png";
  std::vector<std::string> args = {"/usr/bin/python3",
                                   PLACEDB_ROS1_BAG_WRITER,
                                   "",
                                   topic,
                                   compressed ? "compressed" : "raw",
                                   encoding};
  int i = 0;
  for (const auto& path : imagePaths(seq)) {
    int width = 0, height = 0, step = 0;
    const std::string bytes = payload(path, encoding, width, height, step);
    const fs::path file = frames / std::to_string(i++);
    std::ofstream out(file, std::ios::binary);
    if (!compressed) out << width << ' ' << height << ' ' << step << '\n';
    out << bytes;
    args.push_back(file.string());
  }
  const fs::path bag = dir / ("images_" + encoding + ".bag");
  args[2] = bag.string();
  const auto r = run(args, dir);
  EXPECT_EQ(r.exit_code, 0) << describe(r);
  return bag;
}

// ROS 2's CDR: little-endian, each value aligned to its size from the end of the 4-byte
// encapsulation header (0x00 0x01 = CDR little-endian), strings counted with their NUL.
class Cdr {
 public:
  Cdr() : bytes_{0, 1, 0, 0} {}
  void u32(std::uint32_t v) {
    while ((bytes_.size() - 4) % 4) bytes_.push_back(0);
    for (int i = 0; i < 4; ++i) bytes_.push_back(static_cast<char>(v >> (8 * i)));
  }
  void u8(std::uint8_t v) { bytes_.push_back(static_cast<char>(v)); }
  void string(const std::string& s) {
    u32(static_cast<std::uint32_t>(s.size() + 1));
    bytes_ += s;
    bytes_.push_back('\0');
  }
  void sequence(const std::string& s) {
    u32(static_cast<std::uint32_t>(s.size()));
    bytes_ += s;
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

// A bag folder as `ros2 bag record` (rosbag2, sqlite3 storage) leaves it: metadata.yaml and
// NAME_0.db3 with rosbag2's tables; the images' topic, and a second topic of another type.
fs::path writeRos2Bag(const fs::path& seq, const fs::path& dir, const std::string& topic,
                      const std::string& encoding) {
  const fs::path folder = dir / ("ros2_" + encoding);
  fs::create_directories(folder);
  const bool compressed = encoding == "png";
  const std::string type = compressed ? "sensor_msgs/msg/CompressedImage" : "sensor_msgs/msg/Image";
  std::ofstream(folder / "metadata.yaml")
      << "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n"
      << "  relative_file_paths:\n    - ros2_" << encoding << "_0.db3\n";
  sqlite3* db = nullptr;
  const fs::path file = folder / ("ros2_" + encoding + "_0.db3");
  EXPECT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
  const std::string schema =
      "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY,ros_distro TEXT NOT NULL);"
      "CREATE TABLE metadata(id INTEGER PRIMARY KEY,metadata_version INTEGER NOT NULL,"
      "metadata TEXT NOT NULL);"
      "CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT NULL,"
      "serialization_format TEXT NOT NULL,offered_qos_profiles TEXT NOT NULL);"
      "CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,"
      "timestamp INTEGER NOT NULL, data BLOB NOT NULL);"
      "CREATE INDEX timestamp_idx ON messages (timestamp ASC);"
      "INSERT INTO schema VALUES (3, 'humble');"
      "INSERT INTO topics VALUES (1, '" +
      topic + "', '" + type + "', 'cdr', ''), (2, '/rosout', 'rcl_interfaces/msg/Log', 'cdr', '');";
  EXPECT_EQ(sqlite3_exec(db, schema.c_str(), nullptr, nullptr, nullptr), SQLITE_OK)
      << sqlite3_errmsg(db);
  sqlite3_stmt* insert = nullptr;
  sqlite3_prepare_v2(db, "INSERT INTO messages (topic_id, timestamp, data) VALUES (?1, ?2, ?3)", -1,
                     &insert, nullptr);
  int i = 0;
  for (const auto& path : imagePaths(seq)) {
    int width = 0, height = 0, step = 0;
    const std::string bytes = payload(path, encoding, width, height, step);
    Cdr m;
    m.u32(static_cast<std::uint32_t>(kFirstStampSec + i));  // header.stamp.sec (int32)
    m.u32(static_cast<std::uint32_t>(i * 1000));            // header.stamp.nanosec
    m.string("camera");
    if (compressed) {
      m.string(encoding);
      m.sequence(bytes);
    } else {
      m.u32(static_cast<std::uint32_t>(height));
      m.u32(static_cast<std::uint32_t>(width));
      m.string(encoding);
      m.u8(0);
      m.u32(static_cast<std::uint32_t>(step));
      m.sequence(bytes);
    }
    const std::int64_t time = (kFirstStampSec + i) * 1000000000LL + i * 1000;
    for (int topic_id : {1, 2}) {
      const std::string data = topic_id == 1 ? m.bytes() : std::string(8, '\0');
      sqlite3_bind_int(insert, 1, topic_id);
      sqlite3_bind_int64(insert, 2, time);
      sqlite3_bind_blob(insert, 3, data.data(), static_cast<int>(data.size()), SQLITE_TRANSIENT);
      EXPECT_EQ(sqlite3_step(insert), SQLITE_DONE);
      sqlite3_reset(insert);
    }
    ++i;
  }
  sqlite3_finalize(insert);
  sqlite3_close(db);
  return folder;
}

// Every column but the times and the stamp is the same, row by row.
void expectSameDecisions(const fs::path& expected, const fs::path& actual) {
  const auto a = cli::readCsv(expected), b = cli::readCsv(actual);
  ASSERT_EQ(a.header, b.header);
  ASSERT_EQ(a.rows.size(), b.rows.size()) << actual;
  const std::vector<std::string> skip = {"time_ms",       "features_ms",     "quantisation_ms",
                                         "likelihood_ms", "filter_ms",       "memory_ms",
                                         "storage_ms",    "verification_ms", "stamp_ns"};
  for (std::size_t r = 0; r < a.rows.size(); ++r) {
    for (std::size_t c = 0; c < a.header.size(); ++c) {
      if (std::find(skip.begin(), skip.end(), a.header[c]) != skip.end()) continue;
      ASSERT_EQ(a.rows[r][c], b.rows[r][c]) << actual << " row " << r << " " << a.header[c];
    }
  }
}

void expectStamps(const fs::path& log) {
  const auto table = cli::readCsv(log);
  const int frame = table.column("frame"), stamp = table.column("stamp_ns");
  ASSERT_GE(stamp, 0);
  for (std::size_t r = 0; r < table.rows.size(); ++r) {
    const std::int64_t i = std::stoll(table.cell(r, frame));
    EXPECT_EQ(table.cell(r, stamp), std::to_string((kFirstStampSec + i) * 1000000000LL + i * 1000))
        << log << " row " << r;
  }
}

fs::path listRun(const fs::path& seq, const fs::path& dir) {
  const fs::path log = dir / "list.csv";
  const auto r = placedb({"map", (dir / "list.placedb").string(), (seq / "frames.txt").string(),
                          "-q", "--log", log.string()},
                         dir);
  EXPECT_EQ(r.exit_code, 0) << describe(r);
  const auto table = cli::readCsv(log);
  EXPECT_GT(table.rows.size(), 100u);
  // The comparison covers accepted closures, not only new places.
  int accepted = 0;
  for (std::size_t r = 0; r < table.rows.size(); ++r)
    accepted += table.cell(r, table.column("accepted")) == "1";
  EXPECT_GT(accepted, 10) << log;
  return log;
}

TEST(CliBags, Ros1BagsMapAsTheListFileDoes) {
  if (!fs::exists("/usr/lib/python3/dist-packages/rosbag"))
    GTEST_SKIP() << "python3-rosbag is not installed (scripts/install-deps.sh installs it)";
  auto seq = smallSequence(200);
  auto dir = scratchDir("CliBags_ros1");
  const fs::path expected = listRun(seq, dir);
  for (const std::string encoding : {"bgr8", "rgb8", "mono8", "mono16", "png"}) {
    const fs::path bag = writeRos1Bag(seq, dir, "/camera/image", encoding);
    const fs::path log = dir / (encoding + ".csv");
    const auto map = dir / (encoding + ".placedb");
    const auto r = placedb({"map", map.string(), bag.string(), "-q", "--log", log.string()}, dir);
    ASSERT_EQ(r.exit_code, 0) << encoding << ": " << describe(r);
    expectSameDecisions(expected, log);
    expectStamps(log);
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(map.c_str(), &db), SQLITE_OK);
    sqlite3_stmt* s = nullptr;
    sqlite3_prepare_v2(db, "SELECT stamp_ns FROM v_frames WHERE source_index = 7", -1, &s, nullptr);
    ASSERT_EQ(sqlite3_step(s), SQLITE_ROW);
    EXPECT_EQ(sqlite3_column_int64(s, 0), (kFirstStampSec + 7) * 1000000000LL + 7000);
    sqlite3_finalize(s);
    sqlite3_close(db);
  }
}

TEST(CliBags, Ros2BagMapsAsTheListFileDoesAndResumes) {
  auto seq = smallSequence(200);
  auto dir = scratchDir("CliBags_ros2");
  const fs::path expected = listRun(seq, dir);
  for (const std::string encoding : {"bgr8", "png"}) {
    const fs::path bag = writeRos2Bag(seq, dir, "/camera/image", encoding);
    const fs::path log = dir / (encoding + ".csv");
    const auto map = dir / (encoding + ".placedb");
    std::vector<std::string> args = {"map", map.string(), bag.string(),
                                     "-q",  "--log",      log.string()};
    // Stopped after 50 frames and resumed: the same rows as one run.
    auto first = args;
    first.insert(first.end(), {"--stop-after", "50", "--topic", "/camera/image"});
    ASSERT_EQ(placedb(first, dir).exit_code, 0);
    args.erase(args.begin() + 3);  // without -q: the closure lines
    const auto r = placedb(args, dir);
    ASSERT_EQ(r.exit_code, 0) << encoding << ": " << describe(r);
    expectSameDecisions(expected, log);
    expectStamps(log);
    // Each closure line names its frames with their stamps (SESSION:INDEX@SECONDS).
    const std::regex stamped(
        "placedb: frame 1:[0-9]+@[0-9]+\\.[0-9]{9} closes a loop on "
        "frames? 1:[0-9]+@[0-9]+\\.[0-9]{9}( 1:[0-9]+@[0-9]+\\.[0-9]{9})* .*");
    int closure_lines = 0;
    for (const auto& line : lines(r.err))
      if (line.find("closes a loop") != std::string::npos) {
        ++closure_lines;
        EXPECT_TRUE(std::regex_match(line, stamped)) << line;
      }
    EXPECT_GT(closure_lines, 0) << r.err;
    // The stamps travel with the graph too: one per frame a location stands for.
    const auto csv = dir / (encoding + "_graph");
    ASSERT_EQ(placedb({"export", map.string(), csv.string(), "--format", "csv"}, dir).exit_code, 0);
    const auto locations = cli::readCsv(csv / "locations.csv");
    const int frames = locations.column("frames"), stamps = locations.column("stamps_ns");
    ASSERT_GE(stamps, 0);
    const std::string first_frames = locations.cell(0, frames);
    EXPECT_EQ(first_frames.substr(0, first_frames.find(' ')), "1:0");
    EXPECT_EQ(locations.cell(0, stamps).substr(0, 19),
              std::to_string(kFirstStampSec) + "000000000");
    const auto graphml = dir / (encoding + ".graphml");
    ASSERT_EQ(placedb({"export", map.string(), graphml.string()}, dir).exit_code, 0);
    EXPECT_NE(bytesOf(graphml).find("<data key=\"stamps_ns\">" + std::to_string(kFirstStampSec)),
              std::string::npos);
  }
}

TEST(CliBags, WhatABagCannotGiveIsOneLineThatCreatesNothing) {
  auto seq = smallSequence(3);
  auto dir = scratchDir("CliBags_refused");
  const auto map = (dir / "m.placedb").string();
  // An encoding placedb does not read.
  const fs::path yuv = writeRos2Bag(seq, dir, "/camera/image", "yuv422");
  expectCleanError(placedb({"map", map, yuv.string()}, dir), 3, "yuv422");
  // No image topic at all.
  const fs::path none = dir / "none";
  fs::create_directories(none);
  std::ofstream(none / "metadata.yaml") << "rosbag2_bagfile_information:\n  version: 5\n";
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((none / "none_0.db3").c_str(), &db), SQLITE_OK);
    sqlite3_exec(db,
                 "CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT "
                 "NULL,serialization_format TEXT NOT NULL,offered_qos_profiles TEXT NOT NULL);"
                 "CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,"
                 "timestamp INTEGER NOT NULL, data BLOB NOT NULL);"
                 "INSERT INTO topics VALUES (1, '/rosout', 'rcl_interfaces/msg/Log', 'cdr', '');",
                 nullptr, nullptr, nullptr);
    sqlite3_close(db);
  }
  expectCleanError(placedb({"map", map, none.string()}, dir), 3, "no image topic");
  // An image topic without a message, like a list without an image path.
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((none / "none_0.db3").c_str(), &db), SQLITE_OK);
    sqlite3_exec(db,
                 "INSERT INTO topics VALUES (2, '/camera/image', 'sensor_msgs/msg/Image', "
                 "'cdr', '');",
                 nullptr, nullptr, nullptr);
    sqlite3_close(db);
  }
  expectCleanError(placedb({"map", map, none.string()}, dir), 3, "holds no message");
  // A topic it does not hold, a topic of another type, a topic for a source that is no bag.
  const fs::path good = writeRos2Bag(seq, dir, "/camera/image", "bgr8");
  expectCleanError(placedb({"map", map, good.string(), "--topic", "/cam"}, dir), 2,
                   "/camera/image");
  expectCleanError(placedb({"map", map, good.string(), "--topic", "/rosout"}, dir), 2,
                   "rcl_interfaces/msg/Log");
  expectCleanError(
      placedb({"map", map, (seq / "frames.txt").string(), "--topic", "/camera/image"}, dir), 2,
      "--topic");
  EXPECT_FALSE(fs::exists(map));
  EXPECT_FALSE(fs::exists(map + "-lock"));
}

}  // namespace
}  // namespace placedb::testing
