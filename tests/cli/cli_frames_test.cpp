// How the command line names frames and poses to a user (issue #50): every frame as
// SESSION:INDEX with its stamp in `query` (text and JSON) and in the g2o export, a pose with the
// frame it is relative to or a verified match's reason for having none, and a track of stamped
// poses giving the export real vertices and odometry edges.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "cli_scratch.h"
#include "file_bytes.h"
#include "placedb/map.h"

namespace placedb::testing {
namespace {

namespace fs = std::filesystem;

constexpr std::int64_t kFirstStamp = 1700000000'000000000;  // ns
constexpr std::int64_t kFramePeriod = 100'000'000;          // 0.1 s

std::vector<std::string> imagesOf(const fs::path& seq) {
  std::vector<std::string> paths;
  std::ifstream list(seq / "frames.txt");
  for (std::string line; std::getline(list, line);)
    if (!line.empty()) paths.push_back((seq / line).string());
  return paths;
}

// The sequence mapped through the library with a stamp on every frame (as a bag's would be),
// with or without camera intrinsics.
fs::path stampedMap(const fs::path& seq, const fs::path& dir, bool intrinsics) {
  const fs::path path = dir / (intrinsics ? "posed.placedb" : "plain.placedb");
  Options options;
  if (intrinsics) {
    options.fx = options.fy = 190;
    options.cx = 120;
    options.cy = 90;
  }
  auto map = Map::open(path.string(), options);
  map->beginSession((seq / "frames.txt").string());
  const auto images = imagesOf(seq);
  for (std::size_t i = 0; i < images.size(); ++i)
    map->process(cv::imread(images[i]), static_cast<std::int64_t>(i), images[i],
                 kFirstStamp + static_cast<std::int64_t>(i) * kFramePeriod);
  map->close();
  return path;
}

std::int64_t stampOf(std::int64_t index) { return kFirstStamp + index * kFramePeriod; }

// "1700000001.200000000" for frame 12.
std::string stampText(std::int64_t index) {
  const std::int64_t ns = stampOf(index);
  char text[40];
  std::snprintf(text, sizeof text, "%lld.%09lld", static_cast<long long>(ns / 1000000000),
                static_cast<long long>(ns % 1000000000));
  return text;
}

class CliFrames : public ::testing::Test {
 protected:
  void SetUp() override {
    seq_ = smallSequence(30);
    dir_ = scratchDir("CliFrames");
  }
  fs::path seq_, dir_;
};

TEST_F(CliFrames, QueryNamesStampsAndThePosesFrameOrWhyThereIsNone) {
  const fs::path posed = stampedMap(seq_, dir_, true), plain = stampedMap(seq_, dir_, false);
  const std::string image = imagesOf(seq_)[12];
  for (const fs::path& map : {posed, plain}) {
    auto r = placedb({"query", map.string(), image, "--top", "3", "--json"}, dir_);
    ASSERT_EQ(r.exit_code, 0) << describe(r);
    const auto answer = nlohmann::json::parse(r.out).at(0);
    ASSERT_EQ(answer["verdict"], "known") << r.out;
    int verified = 0, posed_matches = 0;
    for (const auto& m : answer["matches"]) {
      for (const auto& f : m["frames"])
        EXPECT_EQ(f["stamp_ns"], stampOf(f["source_index"].get<std::int64_t>())) << f;
      if (!m["verified"].get<bool>()) continue;
      ++verified;
      ASSERT_TRUE(m.contains("pose")) << m;
      if (m["pose"].is_null()) {
        // A verified match without a pose says why.
        ASSERT_TRUE(m.contains("no_pose_reason")) << m;
        EXPECT_FALSE(m["no_pose_reason"].get<std::string>().empty()) << m;
        if (map == plain) {
          EXPECT_NE(m["no_pose_reason"].get<std::string>().find("no camera intrinsics"),
                    std::string::npos)
              << m;
        }
        continue;
      }
      ++posed_matches;
      // The names Python uses, and the frame the pose is relative to: the location's first.
      EXPECT_EQ(m["pose"]["rotation_xyzw"].size(), 4u) << m;
      EXPECT_EQ(m["pose"]["translation"].size(), 3u) << m;
      EXPECT_EQ(m["pose"]["relative_to"], m["frames"][0]) << m;
    }
    EXPECT_GT(verified, 0) << r.out;
    EXPECT_EQ(posed_matches > 0, map == posed) << r.out;

    auto text = placedb({"query", map.string(), image, "--top", "3"}, dir_);
    ASSERT_EQ(text.exit_code, 0) << describe(text);
    EXPECT_NE(text.out.find("frame 1:12@" + stampText(12) + "  " + image), std::string::npos)
        << text.out;
    EXPECT_NE(text.out.find(map == posed ? "pose relative to 1:" : "no pose: no camera intrinsics"),
              std::string::npos)
        << text.out;
  }
}

// The poses of a straight drive along x, for the even frames and the last: the odd ones are
// interpolated.
void writePoses(const fs::path& csv, int frames) {
  std::ofstream out(csv);
  out << "stamp_ns,x,y,z,qx,qy,qz,qw\n";
  for (int i = 0; i < frames; ++i)
    if (i % 2 == 0 || i == frames - 1) out << stampOf(i) << "," << i << ",0,0,0,0,0,1\n";
}

struct G2o {
  std::map<std::int64_t, double> vertex_x;           // location -> x
  std::map<std::int64_t, std::int64_t> first_frame;  // location -> its first frame's index
  std::vector<std::pair<std::pair<std::int64_t, std::int64_t>, double>> odometry;  // (a,b), tx
  std::string text;
};

G2o readG2o(const fs::path& path) {
  G2o g;
  g.text = readBytes(path);
  std::istringstream in(g.text);
  std::int64_t comment_location = -1, comment_frame = -1;
  bool closures = false;
  for (std::string line; std::getline(in, line);) {
    std::istringstream fields(line);
    std::string tag;
    fields >> tag;
    if (line.rfind("# placedb location ", 0) == 0) {
      std::string word, frames;
      std::istringstream c(line.substr(19));
      c >> comment_location >> word >> frames;  // "ID frames 1:K@STAMP ..."
      comment_frame = std::stoll(frames.substr(frames.find(':') + 1));
    } else if (tag == "VERTEX_SE3:QUAT") {
      std::int64_t id = 0;
      double x = 0;
      fields >> id >> x;
      g.vertex_x[id] = x;
      if (id == comment_location) g.first_frame[id] = comment_frame;
    } else if (line.rfind("# placedb appearance-only", 0) == 0 ||
               line.rfind("# placedb pose", 0) == 0) {
      closures = true;
    } else if (tag == "EDGE_SE3:QUAT" && !closures) {
      std::int64_t a = 0, b = 0;
      double tx = 0;
      fields >> a >> b >> tx;
      g.odometry.push_back({{a, b}, tx});
    }
  }
  return g;
}

TEST_F(CliFrames, ExportNamesStampsAndTakesPosesFromAStampedTrack) {
  const fs::path map = stampedMap(seq_, dir_, false);
  auto bare = placedb({"export", map.string(), (dir_ / "bare.g2o").string()}, dir_);
  ASSERT_EQ(bare.exit_code, 0) << describe(bare);
  const G2o unplaced = readG2o(dir_ / "bare.g2o");
  EXPECT_NE(unplaced.text.find("# placedb location 1 frames 1:0@" + stampText(0)),
            std::string::npos)
      << unplaced.text.substr(0, 400);
  for (const auto& [id, x] : unplaced.vertex_x) EXPECT_EQ(x, 0.0) << "location " << id;

  writePoses(dir_ / "poses.csv", 30);
  auto placed = placedb({"export", map.string(), (dir_ / "placed.g2o").string(), "--poses",
                         (dir_ / "poses.csv").string()},
                        dir_);
  ASSERT_EQ(placed.exit_code, 0) << describe(placed);
  const G2o g = readG2o(dir_ / "placed.g2o");
  ASSERT_FALSE(g.vertex_x.empty());
  int moved = 0;
  for (const auto& [id, x] : g.vertex_x) {
    ASSERT_TRUE(g.first_frame.count(id)) << "location " << id << " has no frame comment";
    // The drive goes 1 along x a frame: a location sits at its first frame's index.
    EXPECT_NEAR(x, static_cast<double>(g.first_frame.at(id)), 1e-9) << "location " << id;
    moved += x != 0.0;
  }
  EXPECT_GT(moved, 0);
  EXPECT_NE(placed.err.find(std::to_string(g.vertex_x.size()) + " of them placed from"),
            std::string::npos)
      << placed.err;
  ASSERT_FALSE(g.odometry.empty());
  for (const auto& [link, tx] : g.odometry)
    EXPECT_NEAR(tx, g.vertex_x.at(link.second) - g.vertex_x.at(link.first), 1e-9)
        << link.first << " -> " << link.second;

  // The CSV export carries the same poses.
  auto csv = placedb({"export", map.string(), (dir_ / "csv").string(), "--format", "csv", "--poses",
                      (dir_ / "poses.csv").string()},
                     dir_);
  ASSERT_EQ(csv.exit_code, 0) << describe(csv);
  EXPECT_EQ(lines(readBytes(dir_ / "csv" / "locations.csv")).front(),
            "location,session,tier,weight,frames,stamps_ns,x,y,z,qx,qy,qz,qw");

  // A track that covers no frame, or that is not one, is refused and writes nothing.
  std::ofstream(dir_ / "elsewhere.csv") << "stamp_ns,x,y,z,qx,qy,qz,qw\n5,0,0,0,0,0,0,1\n";
  expectCleanError(placedb({"export", map.string(), (dir_ / "no.g2o").string(), "--poses",
                            (dir_ / "elsewhere.csv").string()},
                           dir_),
                   2, "elsewhere.csv");
  std::ofstream(dir_ / "columns.csv") << "time,x,y\n1,2,3\n";
  expectCleanError(placedb({"export", map.string(), (dir_ / "no.g2o").string(), "--poses",
                            (dir_ / "columns.csv").string()},
                           dir_),
                   2, "columns.csv: no column stamp_ns");
  EXPECT_FALSE(fs::exists(dir_ / "no.g2o"));
}

}  // namespace
}  // namespace placedb::testing
