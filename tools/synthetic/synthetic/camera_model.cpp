#include "synthetic/camera_model.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace placedb::synthetic {

CameraIntrinsics CameraIntrinsics::fromHorizontalFov(int width, int height, double hfov_radians) {
  CameraIntrinsics camera;
  camera.width = width;
  camera.height = height;
  camera.focal = 0.5 * width / std::tan(0.5 * hfov_radians);
  camera.cx = 0.5 * width;
  camera.cy = 0.5 * height;
  return camera;
}

double CameraIntrinsics::verticalFov() const { return 2.0 * std::atan(0.5 * height / focal); }

cv::Matx33d pixelRays(const Pose& pose, const CameraIntrinsics& camera) {
  const double ch = std::cos(pose.heading), sh = std::sin(pose.heading);
  const double cp = std::cos(pose.pitch), sp = std::sin(pose.pitch);
  const cv::Vec3d forward(cp * ch, cp * sh, -sp);  // optical axis
  const cv::Vec3d right(sh, -ch, 0);               // image +u
  const cv::Vec3d down = forward.cross(right);     // image +v
  // Ray of pixel (u, v): right*(u-cx)/f + down*(v-cy)/f + forward.
  const double f = camera.focal;
  const cv::Vec3d offset = forward - right * (camera.cx / f) - down * (camera.cy / f);
  return cv::Matx33d(right[0] / f, down[0] / f, offset[0],  //
                     right[1] / f, down[1] / f, offset[1],  //
                     right[2] / f, down[2] / f, offset[2]);
}

cv::Matx33d imageToPlane(const Pose& pose, const CameraIntrinsics& camera,
                         const PlaneFrame& plane) {
  // The ray C + l*d meets the plane at l = n.(O - C) / n.d. With w = n.d as the homogeneous
  // scale, s * w = a.(C - O) n.d + n.(O - C) a.d, and likewise for t: linear in d, so linear in
  // the pixel.
  const cv::Vec3d camera_centre(pose.x, pose.y, pose.height);
  const cv::Vec3d n = plane.s_axis.cross(plane.t_axis);
  const cv::Vec3d to_camera = camera_centre - plane.origin;
  const double n_gap = -n.dot(to_camera);
  const cv::Vec3d s_row = n * plane.s_axis.dot(to_camera) + plane.s_axis * n_gap;
  const cv::Vec3d t_row = n * plane.t_axis.dot(to_camera) + plane.t_axis * n_gap;
  const cv::Matx33d to_plane(s_row[0], s_row[1], s_row[2],  //
                             t_row[0], t_row[1], t_row[2],  //
                             n[0], n[1], n[2]);
  return to_plane * pixelRays(pose, camera);
}

cv::Matx33d imageToGround(const Pose& pose, const CameraIntrinsics& camera) {
  // imageToPlane()'s rule for n = (0, 0, 1), written out (and scaled by -1) so the ground scene's
  // arithmetic, and so its images, stay exactly what they were.
  const cv::Matx33d to_ground(pose.height, 0, -pose.x,  //
                              0, pose.height, -pose.y,  //
                              0, 0, -1);
  return to_ground * pixelRays(pose, camera);
}

cv::Matx33d groundToImage(const Pose& pose, const CameraIntrinsics& camera) {
  return imageToGround(pose, camera).inv();
}

cv::Matx33d relativeHomography(const Pose& from, const Pose& to, const CameraIntrinsics& camera) {
  return groundToImage(to, camera) * imageToGround(from, camera);
}

std::array<cv::Point2d, 4> groundFootprint(const Pose& pose, const CameraIntrinsics& camera) {
  const cv::Matx33d h = imageToGround(pose, camera);
  const double w = camera.width, ht = camera.height;
  const cv::Vec3d corners[4] = {{0, 0, 1}, {w, 0, 1}, {w, ht, 1}, {0, ht, 1}};
  std::array<cv::Point2d, 4> quad;
  for (int k = 0; k < 4; ++k) {
    const cv::Vec3d g = h * corners[k];
    quad[k] = cv::Point2d(g[0] / g[2], g[1] / g[2]);
  }
  return quad;
}

double polygonArea(const std::array<cv::Point2d, 4>& quad) {
  double twice = 0;
  for (int k = 0; k < 4; ++k) {
    const cv::Point2d& a = quad[k];
    const cv::Point2d& b = quad[(k + 1) % 4];
    twice += a.x * b.y - a.y * b.x;
  }
  return 0.5 * std::abs(twice);
}

double footprintIntersection(const std::array<cv::Point2d, 4>& a,
                             const std::array<cv::Point2d, 4>& b) {
  // Work relative to a's first corner so float precision holds far from the origin.
  const cv::Point2d origin = a[0];
  std::vector<cv::Point2f> pa, pb;
  for (int k = 0; k < 4; ++k) {
    pa.emplace_back(cv::Point2f(a[k] - origin));
    pb.emplace_back(cv::Point2f(b[k] - origin));
  }
  std::vector<cv::Point2f> shared;
  const double inter = cv::intersectConvexConvex(pa, pb, shared, true);
  return std::max(inter, 0.0);
}

double footprintOverlap(const std::array<cv::Point2d, 4>& a, const std::array<cv::Point2d, 4>& b) {
  const double inter = footprintIntersection(a, b);
  if (inter <= 0) return 0;
  const double uni = polygonArea(a) + polygonArea(b) - inter;
  return uni > 0 ? inter / uni : 0;
}

}  // namespace placedb::synthetic
