#include "report/pose_track.h"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <initializer_list>
#include <string>

#include "frame_log.h"
#include "placedb/error.h"

namespace placedb::cli {
namespace {

using Quaternion = std::array<double, 4>;  // x, y, z, w

Quaternion multiply(const Quaternion& a, const Quaternion& b) {
  const double ax = a[0], ay = a[1], az = a[2], aw = a[3];
  const double bx = b[0], by = b[1], bz = b[2], bw = b[3];
  return {aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
          aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz};
}

Quaternion conjugate(const Quaternion& q) { return {-q[0], -q[1], -q[2], q[3]}; }

std::array<double, 3> rotate(const Quaternion& q, const std::array<double, 3>& v) {
  const Quaternion p = multiply(multiply(q, {v[0], v[1], v[2], 0}), conjugate(q));
  return {p[0], p[1], p[2]};
}

std::optional<Quaternion> normalised(const Quaternion& q) {
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!(n > 0) || !std::isfinite(n)) return std::nullopt;
  return Quaternion{q[0] / n, q[1] / n, q[2] / n, q[3] / n};
}

Quaternion slerp(const Quaternion& a, Quaternion b, double t) {
  double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
  if (dot < 0) {  // the shorter way round
    for (double& v : b) v = -v;
    dot = -dot;
  }
  double wa = 1 - t, wb = t;
  if (dot < 0.9995) {
    const double angle = std::acos(std::min(1.0, dot));
    wa = std::sin((1 - t) * angle) / std::sin(angle);
    wb = std::sin(t * angle) / std::sin(angle);
  }
  Quaternion q;
  for (std::size_t i = 0; i < 4; ++i) q[i] = wa * a[i] + wb * b[i];
  return normalised(q).value_or(a);
}

// The column of `table` under any of `names`; -1 when none is there.
int columnOf(const CsvTable& table, std::initializer_list<const char*> names) {
  for (const char* name : names)
    if (const int c = table.column(name); c >= 0) return c;
  return -1;
}

}  // namespace

Pose3 between(const Pose3& a, const Pose3& b) {
  const Quaternion inverse = conjugate(a.rotation_xyzw);
  Pose3 out;
  out.rotation_xyzw = multiply(inverse, b.rotation_xyzw);
  out.position = rotate(inverse, {b.position[0] - a.position[0], b.position[1] - a.position[1],
                                  b.position[2] - a.position[2]});
  return out;
}

PoseTrack::PoseTrack(std::vector<StampedPose> poses) : poses_(std::move(poses)) {
  std::stable_sort(poses_.begin(), poses_.end(), [](const StampedPose& a, const StampedPose& b) {
    return a.stamp_ns < b.stamp_ns;
  });
  for (std::size_t i = 0; i < poses_.size(); ++i) {
    if (i > 0 && poses_[i].stamp_ns == poses_[i - 1].stamp_ns)
      throw Error(ErrorCode::kInvalidArgument,
                  fmt::format("two poses with stamp {}", poses_[i].stamp_ns));
    const auto q = normalised(poses_[i].pose.rotation_xyzw);
    if (!q)
      throw Error(
          ErrorCode::kInvalidArgument,
          fmt::format("the pose at stamp {} has a quaternion of zero length", poses_[i].stamp_ns));
    poses_[i].pose.rotation_xyzw = *q;
  }
}

std::optional<Pose3> PoseTrack::at(std::int64_t stamp_ns) const {
  const auto after =
      std::lower_bound(poses_.begin(), poses_.end(), stamp_ns,
                       [](const StampedPose& p, std::int64_t stamp) { return p.stamp_ns < stamp; });
  if (after == poses_.end()) return std::nullopt;
  if (after->stamp_ns == stamp_ns) return after->pose;
  if (after == poses_.begin()) return std::nullopt;
  const StampedPose& a = *(after - 1);
  const StampedPose& b = *after;
  // In double from the differences: the stamps themselves exceed a double's exact integers.
  const double t =
      static_cast<double>(stamp_ns - a.stamp_ns) / static_cast<double>(b.stamp_ns - a.stamp_ns);
  Pose3 pose;
  for (std::size_t i = 0; i < 3; ++i)
    pose.position[i] = a.pose.position[i] + t * (b.pose.position[i] - a.pose.position[i]);
  pose.rotation_xyzw = slerp(a.pose.rotation_xyzw, b.pose.rotation_xyzw, t);
  return pose;
}

PoseTrack readPoseCsv(const std::filesystem::path& path) {
  const std::string name = path.string();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw Error(ErrorCode::kIo, fmt::format("cannot read poses {}: {}", name,
                                            std::filesystem::exists(path, ec) ? "not a regular file"
                                                                              : "no such file"));
  const CsvTable table = readCsv(path);
  const auto field = [](const char* ours, const char* ros) { return std::pair(ours, ros); };
  const std::pair<const char*, const char*> wanted[] = {
      field("stamp_ns", "field.header.stamp"),      field("x", "field.pose.pose.position.x"),
      field("y", "field.pose.pose.position.y"),     field("z", "field.pose.pose.position.z"),
      field("qx", "field.pose.pose.orientation.x"), field("qy", "field.pose.pose.orientation.y"),
      field("qz", "field.pose.pose.orientation.z"), field("qw", "field.pose.pose.orientation.w")};
  int columns[8];
  for (std::size_t i = 0; i < 8; ++i) {
    columns[i] = columnOf(table, {wanted[i].first, wanted[i].second});
    if (columns[i] < 0)
      throw Error(ErrorCode::kInvalidArgument,
                  fmt::format("poses {}: no column {} (the header must name stamp_ns,x,y,z,qx,"
                              "qy,qz,qw)",
                              name, wanted[i].first));
  }
  std::vector<StampedPose> poses;
  for (std::size_t r = 0; r < table.rows.size(); ++r) {
    const auto bad = [&](std::size_t i) {
      return Error(ErrorCode::kInvalidArgument,
                   fmt::format("poses {}: row {}: {} is not a number: '{}'", name, r + 2,
                               wanted[i].first, table.cell(r, columns[i])));
    };
    StampedPose p;
    const std::string& stamp = table.cell(r, columns[0]);
    char* end = nullptr;
    errno = 0;
    p.stamp_ns = std::strtoll(stamp.c_str(), &end, 10);
    if (stamp.empty() || *end != '\0' || errno != 0) throw bad(0);
    double values[7];
    for (std::size_t i = 1; i < 8; ++i) {
      const std::string& text = table.cell(r, columns[i]);
      values[i - 1] = std::strtod(text.c_str(), &end);
      if (text.empty() || *end != '\0' || !std::isfinite(values[i - 1])) throw bad(i);
    }
    p.pose.position = {values[0], values[1], values[2]};
    p.pose.rotation_xyzw = {values[3], values[4], values[5], values[6]};
    poses.push_back(p);
  }
  if (poses.empty())
    throw Error(ErrorCode::kInvalidArgument, fmt::format("poses {}: no pose in it", name));
  try {
    return PoseTrack(std::move(poses));
  } catch (const Error& e) {
    throw Error(e.code(), fmt::format("poses {}: {}", name, e.what()));
  }
}

}  // namespace placedb::cli
