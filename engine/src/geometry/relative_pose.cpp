#include "geometry/relative_pose.h"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>

namespace placedb {
namespace {

std::vector<cv::Point2d> normalised(const std::vector<cv::Point2f>& points,
                                    const CameraIntrinsics& k) {
  std::vector<cv::Point2d> out;
  out.reserve(points.size());
  for (const auto& p : points) out.emplace_back((p.x - k.cx) / k.fx, (p.y - k.cy) / k.fy);
  return out;
}

}  // namespace

CameraIntrinsics intrinsicsOf(const Options& options) {
  return {options.fx, options.fy, options.cx, options.cy};
}

std::array<double, 4> quaternionOf(const cv::Matx33d& r) {
  // Shepperd's method: divide by the largest of the four candidates, never by a small one.
  const double trace = r(0, 0) + r(1, 1) + r(2, 2);
  double w, x, y, z;
  if (trace >= r(0, 0) && trace >= r(1, 1) && trace >= r(2, 2)) {
    const double s = 2 * std::sqrt(std::max(0.0, 1 + trace));
    w = s / 4;
    x = (r(2, 1) - r(1, 2)) / s;
    y = (r(0, 2) - r(2, 0)) / s;
    z = (r(1, 0) - r(0, 1)) / s;
  } else if (r(0, 0) >= r(1, 1) && r(0, 0) >= r(2, 2)) {
    const double s = 2 * std::sqrt(std::max(0.0, 1 + r(0, 0) - r(1, 1) - r(2, 2)));
    w = (r(2, 1) - r(1, 2)) / s;
    x = s / 4;
    y = (r(0, 1) + r(1, 0)) / s;
    z = (r(0, 2) + r(2, 0)) / s;
  } else if (r(1, 1) >= r(2, 2)) {
    const double s = 2 * std::sqrt(std::max(0.0, 1 + r(1, 1) - r(0, 0) - r(2, 2)));
    w = (r(0, 2) - r(2, 0)) / s;
    x = (r(0, 1) + r(1, 0)) / s;
    y = s / 4;
    z = (r(1, 2) + r(2, 1)) / s;
  } else {
    const double s = 2 * std::sqrt(std::max(0.0, 1 + r(2, 2) - r(0, 0) - r(1, 1)));
    w = (r(1, 0) - r(0, 1)) / s;
    x = (r(0, 2) + r(2, 0)) / s;
    y = (r(1, 2) + r(2, 1)) / s;
    z = s / 4;
  }
  const double norm = std::sqrt(w * w + x * x + y * y + z * z);
  const double sign = w < 0 ? -1.0 : 1.0;  // q and -q are one rotation: keep w >= 0
  return {sign * w / norm, sign * x / norm, sign * y / norm, sign * z / norm};
}

cv::Matx33d rotationOf(const std::array<double, 4>& q) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  return {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
          2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
          2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
}

std::optional<storage::ClosurePose> relativePose(const std::vector<cv::Point2f>& a,
                                                 const CameraIntrinsics& camera_a,
                                                 const std::vector<cv::Point2f>& b,
                                                 const CameraIntrinsics& camera_b,
                                                 const RelativePoseSettings& s) {
  constexpr std::size_t kFivePoint = 5;
  if (!camera_a.known() || !camera_b.known() || a.size() != b.size() || a.size() < kFivePoint)
    return std::nullopt;
  // In normalised coordinates both cameras are the identity, so two sessions with different
  // cameras compare too; the pixel threshold becomes one in units of the mean focal length.
  const std::vector<cv::Point2d> na = normalised(a, camera_a), nb = normalised(b, camera_b);
  const double focal = (camera_a.fx + camera_a.fy + camera_b.fx + camera_b.fy) / 4;
  const cv::Matx33d identity = cv::Matx33d::eye();
  cv::Mat mask;
  const cv::Mat e = cv::findEssentialMat(na, nb, identity, cv::USAC_ACCURATE, s.confidence,
                                         s.max_error_px / focal, s.iterations, mask);
  if (e.rows < 3 || e.cols != 3) return std::nullopt;
  cv::Mat r, t;
  // findEssentialMat may return several solutions stacked; RANSAC keeps its best first.
  const int in_front = cv::recoverPose(e.rowRange(0, 3), na, nb, identity, r, t, mask);
  if (in_front < s.min_inliers) return std::nullopt;
  const auto q = quaternionOf(cv::Matx33d(r));
  cv::Vec3d direction(t.at<double>(0), t.at<double>(1), t.at<double>(2));
  const double length = cv::norm(direction);
  if (!(length > 0)) return std::nullopt;
  direction /= length;
  storage::ClosurePose pose;
  pose.qw = q[0];
  pose.qx = q[1];
  pose.qy = q[2];
  pose.qz = q[3];
  pose.tx = direction[0];
  pose.ty = direction[1];
  pose.tz = direction[2];
  pose.inliers = in_front;
  return pose;
}

}  // namespace placedb
