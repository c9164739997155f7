#pragma once
// Poses given from outside placedb: where the camera was at each stamp (wheel or visual
// odometry, a SLAM trajectory). placedb measures no metric pose itself; with a track, the graph
// export places each location at its first frame's pose and measures the odometry links
// between locations (graph_export.h: attachPoses).
//
// The CSV form has a header row and one pose a row: `stamp_ns,x,y,z,qx,qy,qz,qw` (columns in any
// order, others ignored): ns since the epoch, as the frames' stamps (a bag message's
// header.stamp); the position, and the rotation as a quaternion in x, y, z, w order. The columns
// of `rostopic echo -p` of a nav_msgs/Odometry topic are taken too (field.header.stamp,
// field.pose.pose.position.x ... field.pose.pose.orientation.w), so `rostopic echo -b run.bag -p
// /odom > odom.csv` gives a track as it is. A ROS node gives its odometry messages to PoseTrack
// directly.
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <vector>

namespace placedb::cli {

struct Pose3 {  // a rigid pose: b's frame in a's is the pose of b relative to a
  std::array<double, 3> position{0, 0, 0};
  std::array<double, 4> rotation_xyzw{0, 0, 0, 1};  // unit quaternion
};

// b seen from a: a's inverse composed with b.
Pose3 between(const Pose3& a, const Pose3& b);

struct StampedPose {
  std::int64_t stamp_ns = 0;
  Pose3 pose;
};

class PoseTrack {
 public:
  // Any order; sorted here. Quaternions are normalised. Throws placedb::Error(kInvalidArgument)
  // for two poses with one stamp or a quaternion of zero length.
  explicit PoseTrack(std::vector<StampedPose> poses);

  // The pose at `stamp_ns`: a pose of the track with that stamp, or one interpolated between
  // the two around it (the position linearly, the rotation by slerp); none before the first
  // stamp or after the last.
  std::optional<Pose3> at(std::int64_t stamp_ns) const;

  std::size_t size() const { return poses_.size(); }
  std::int64_t firstStamp() const { return poses_.empty() ? 0 : poses_.front().stamp_ns; }
  std::int64_t lastStamp() const { return poses_.empty() ? 0 : poses_.back().stamp_ns; }

 private:
  std::vector<StampedPose> poses_;  // by stamp
};

// Throws placedb::Error: kIo when the file cannot be read, kInvalidArgument naming the file, row
// and column of a missing column or a value that is not a number (a header only is an empty
// track, refused too).
PoseTrack readPoseCsv(const std::filesystem::path& path);

}  // namespace placedb::cli
