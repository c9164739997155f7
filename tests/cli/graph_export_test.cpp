// `placedb export`: a closure that stores a relative pose is exported with it, turned into g2o's
// measurement of the edge a -> b; one without is flagged appearance-only in every format.
#include "report/graph_export.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "placedb/error.h"
#include "placedb/storage/sqlite_map_store.h"
#include "test_paths.h"

namespace placedb::cli {
namespace {

namespace fs = std::filesystem;
using storage::ClosurePose;

std::string contentOf(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Four locations, one frame each (frame i at location i), odometry links, and three closures:
// 1-4 measured at frame 4 (the pose of 4's camera in 1's), 1-3 measured at frame 1 (the pose of
// 1's camera in 3's: the export inverts it) and 2-4 without a pose.
fs::path makeMap(const ClosurePose& pose) {
  const auto path = placedb::testing::scratchDir("GraphExportPose") / "m.placedb";
  storage::SqliteMapStore store(path.string(), storage::OpenMode::kReadWrite);
  const std::int64_t session = store.beginSession("src", {}, "test");
  auto tx = store.begin();
  for (std::int64_t i = 1; i <= 4; ++i) {
    storage::FrameRecord frame;
    frame.id = i;
    frame.session_id = session;
    frame.source_index = i - 1;
    frame.location_id = i;
    store.insertFrame(frame);
    store.insertLocation({i, session, 1, storage::Tier::kWm, i});
    store.addCoveredFrame(i, i);
  }
  for (std::int64_t i = 1; i < 4; ++i)
    store.insertLink(i, i + 1, storage::LinkType::kNeighbour, std::nullopt);
  auto closure = [&](std::int64_t frame, std::int64_t other, std::optional<ClosurePose> p) {
    store.insertLink(std::min(frame, other), std::max(frame, other),
                     storage::LinkType::kLoopClosure, 0.9);
    storage::HypothesisRecord h;
    h.frame_id = frame;
    h.best_location_id = other;
    h.posterior = 0.5;
    h.loop_probability = 0.9;
    h.accepted = true;
    h.pose = p;
    store.insertHypothesis(h);
  };
  closure(4, 1, pose);
  closure(1, 3, pose);
  closure(2, 4, std::nullopt);
  tx.commit();
  return path;
}

TEST(GraphExport, PosesTravelAndTheOthersAreAppearanceOnly) {
  // 90 degrees about y, translation along x.
  const double h = std::sqrt(0.5);
  const ClosurePose pose{h, 0, h, 0, 1, 0, 0, 33};
  const auto map = makeMap(pose);
  const MapGraph graph = readMapGraph(map.string());
  std::map<std::pair<std::int64_t, std::int64_t>, GraphLink> closures;
  for (const auto& k : graph.links)
    if (k.type == "loop_closure") closures[{k.location_a, k.location_b}] = k;
  ASSERT_EQ(closures.size(), 3u);

  const auto& direct = closures.at({1, 4});
  ASSERT_TRUE(direct.pose);
  EXPECT_EQ(direct.pose->rotation_xyzw, (std::array<double, 4>{0, h, 0, h}));
  EXPECT_EQ(direct.pose->translation_direction, (std::array<double, 3>{1, 0, 0}));
  EXPECT_EQ(direct.pose->inliers, 33);

  // Stored as 1's camera in 3's: exported as 3's in 1's, R' and -R' t.
  const auto& inverted = closures.at({1, 3});
  ASSERT_TRUE(inverted.pose);
  const auto& q = inverted.pose->rotation_xyzw;
  EXPECT_NEAR(q[1], -h, 1e-12);
  EXPECT_NEAR(q[3], h, 1e-12);
  const auto& t = inverted.pose->translation_direction;  // R' (1,0,0) = (0,0,1) -> (0,0,-1)
  EXPECT_NEAR(t[0], 0, 1e-12);
  EXPECT_NEAR(t[1], 0, 1e-12);
  EXPECT_NEAR(t[2], -1, 1e-12);

  EXPECT_FALSE(closures.at({2, 4}).pose);

  const auto dir = map.parent_path();
  writeMapGraph(graph, "g2o", dir / "g.g2o");
  const std::string g2o = contentOf(dir / "g.g2o");
  EXPECT_NE(g2o.find("# placedb appearance-only 2 4"), std::string::npos) << g2o;
  EXPECT_NE(g2o.find("# placedb pose 1 4 inliers 33"), std::string::npos) << g2o;
  const std::string rotation_only = "0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 1 0 0 1 0 1";
  EXPECT_NE(g2o.find(fmt::format("EDGE_SE3:QUAT 1 4 1 0 0 0 {} 0 {} {}", h, h, rotation_only)),
            std::string::npos)
      << g2o;

  writeMapGraph(graph, "csv", dir / "csv");
  const std::string links = contentOf(dir / "csv" / "links.csv");
  EXPECT_NE(links.find("pose_inliers\n"), std::string::npos) << links;
  EXPECT_NE(links.find("2,4,loop_closure,0.9,1,,,,,,,,\n"), std::string::npos) << links;
  EXPECT_NE(links.find(fmt::format("1,4,loop_closure,0.9,0,0,{},0,{},1,0,0,33\n", h, h)),
            std::string::npos)
      << links;

  writeMapGraph(graph, "graphml", dir / "g.graphml");
  const std::string graphml = contentOf(dir / "g.graphml");
  EXPECT_NE(graphml.find("<data key=\"appearance_only\">false</data><data key=\"qx\">"),
            std::string::npos);
  EXPECT_NE(graphml.find("<data key=\"pose_inliers\">33</data>"), std::string::npos);
  // Directed, a -> b as the pose is measured, and the node ids g2o gives its vertices.
  EXPECT_NE(graphml.find("edgedefault=\"directed\""), std::string::npos);
  EXPECT_NE(graphml.find("<node id=\"1\">"), std::string::npos);
  EXPECT_NE(graphml.find("<edge source=\"1\" target=\"4\">"), std::string::npos);
}

// A track of stamped poses: exact at a stamp, interpolated between two (position linearly,
// rotation by slerp), nothing outside; `rostopic echo -p` columns read as they are.
TEST(PoseTrack, InterpolatesBetweenStampsAndReadsRostopicColumns) {
  const auto dir = placedb::testing::scratchDir("PoseTrack");
  const double h = std::sqrt(0.5);  // 90 degrees about z at stamp 300
  std::ofstream(dir / "odom.csv")
      << "%time,field.header.seq,field.header.stamp,field.pose.pose.position.x,"
         "field.pose.pose.position.y,field.pose.pose.position.z,field.pose.pose.orientation.x,"
         "field.pose.pose.orientation.y,field.pose.pose.orientation.z,"
         "field.pose.pose.orientation.w\n"
      << "1,2,300,2,4,0,0,0," << h << "," << h << "\n"
      << "1,1,100,0,0,0,0,0,0,1\n";
  const PoseTrack track = readPoseCsv(dir / "odom.csv");
  EXPECT_EQ(track.size(), 2u);
  EXPECT_FALSE(track.at(99));
  EXPECT_FALSE(track.at(301));
  const auto exact = track.at(100);
  ASSERT_TRUE(exact);
  EXPECT_EQ(exact->position, (std::array<double, 3>{0, 0, 0}));
  const auto half = track.at(200);
  ASSERT_TRUE(half);
  EXPECT_NEAR(half->position[0], 1, 1e-12);
  EXPECT_NEAR(half->position[1], 2, 1e-12);
  // Half of 90 degrees about z.
  EXPECT_NEAR(half->rotation_xyzw[2], std::sin(M_PI / 8), 1e-12);
  EXPECT_NEAR(half->rotation_xyzw[3], std::cos(M_PI / 8), 1e-12);

  // b seen from a: a turned 90 degrees left at (2, 4) sees a point 1 ahead in x at (1, 0).
  Pose3 a, b;
  a.position = {2, 4, 0};
  a.rotation_xyzw = {0, 0, h, h};
  b.position = {2, 5, 0};
  const Pose3 seen = between(a, b);
  EXPECT_NEAR(seen.position[0], 1, 1e-12);
  EXPECT_NEAR(seen.position[1], 0, 1e-12);
  EXPECT_NEAR(seen.rotation_xyzw[2], -h, 1e-12);

  std::ofstream(dir / "twice.csv")
      << "stamp_ns,x,y,z,qx,qy,qz,qw\n5,0,0,0,0,0,0,1\n5,1,0,0,0,0,0,1\n";
  EXPECT_THROW(readPoseCsv(dir / "twice.csv"), Error);
  std::ofstream(dir / "text.csv") << "stamp_ns,x,y,z,qx,qy,qz,qw\n5,zero,0,0,0,0,0,1\n";
  try {
    readPoseCsv(dir / "text.csv");
    ADD_FAILURE() << "a pose that is not a number was read";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find("text.csv: row 2: x is not a number"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(readPoseCsv(dir / "absent.csv"), Error);
}

}  // namespace
}  // namespace placedb::cli
