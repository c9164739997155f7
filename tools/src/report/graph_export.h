#pragma once
// A map as a graph for pose-graph optimisers and graph tools (`placedb export`): every location
// with the frames it covers, the odometry-order links between consecutive locations and the
// loop-closure links, with the relative pose of a closure where the map stores one.
//
//   csv      OUT is a folder: locations.csv and links.csv
//   graphml  one GraphML file (Gephi, yEd, networkx)
//   g2o      one g2o file: VERTEX_SE3:QUAT per location and EDGE_SE3:QUAT per link, each vertex
//            after a `# placedb location ID frames F...` comment naming its frames as
//            SESSION:INDEX[@STAMP] (frame_names.h). placedb keeps no metric poses: a vertex is
//            at the origin and an odometry edge the identity with a unit information matrix,
//            unless a pose track (pose_track.h) gives the location's pose, and the edge the
//            relative pose of its two ends. A closure link without a measured pose is the
//            identity with unit information, announced by `# placedb appearance-only A B`. A
//            closure with a measured pose (a map made with intrinsics fx fy cx cy) carries its
//            rotation and unit translation direction, with unit information on the rotation
//            and zero on the translation (one camera measures no scale: the optimiser is told
//            nothing about the distance, the direction is in the measurement for tools that
//            read it), announced by `# placedb pose A B inliers N`
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "report/pose_track.h"

namespace placedb::cli {

struct GraphFrame {
  std::int64_t session_id = 0;
  std::int64_t source_index = 0;
  std::optional<std::int64_t> stamp_ns;  // the source's stamp (a bag message's header.stamp)
};

struct GraphLocation {
  std::int64_t id = 0;
  std::int64_t session_id = 0;
  std::string tier;  // stm | wm | ltm
  std::int64_t weight = 0;
  std::vector<GraphFrame> frames;  // by frame id
  // From a pose track (attachPoses): the pose at the stamp of the location's first frame, the
  // frame whose camera its closures' poses are relative to.
  std::optional<Pose3> pose;
};

// Where the geometric check measured it: the pose of b's camera in a's (g2o's measurement of
// an edge a -> b): a point X in b's camera coordinates is R X + s t in a's, R the rotation and
// t the translation direction (unit length; a monocular check knows no scale).
struct RelativePose {
  std::array<double, 4> rotation_xyzw{0, 0, 0, 1};
  std::array<double, 3> translation_direction{0, 0, 0};
  std::int64_t inliers = 0;  // pairs that agreed with the essential matrix
};

struct GraphLink {
  std::int64_t location_a = 0, location_b = 0;  // a < b
  std::string type;                             // odometry | loop_closure | merge
  std::optional<double> score;
  std::optional<RelativePose> pose;  // none: appearance only
  // An odometry link between two locations a pose track placed: b's pose in a's.
  std::optional<Pose3> odometry;
};

struct MapGraph {
  std::vector<GraphLocation> locations;  // by id
  std::vector<GraphLink> links;          // by (a, b)
};

// Reads the map read-only. Throws placedb::Error(kIo) when it is missing, and the storage
// errors of a refused map.
MapGraph readMapGraph(const std::string& map_path);

// Places each location whose first frame has a stamp within the track, and measures each
// odometry link between two placed locations. Returns the locations placed.
std::size_t attachPoses(MapGraph& graph, const PoseTrack& track);

// Throws placedb::Error(kInvalidArgument) for another format, kIo when OUT cannot be written.
void writeMapGraph(const MapGraph& graph, const std::string& format,
                   const std::filesystem::path& out);

}  // namespace placedb::cli
