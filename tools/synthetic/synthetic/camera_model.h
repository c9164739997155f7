#pragma once
// A pinhole camera in a world of planes: every image of one plane is a homography of it. The
// ground scene is one infinite plane (the ground); the canyon scenes (canyon.h) are a few.
#include <array>

#include <opencv2/core.hpp>

namespace placedb::synthetic {

// Ground coordinates are metres, x east, y north, z up; the ground is z = 0.
struct Pose {
  double x = 0, y = 0;
  double heading = 0;  // radians, counter-clockwise from +x: the direction of travel
  double height = 6;   // metres above the ground
  double pitch = 1.0;  // radians below the horizon of the optical axis
};

struct CameraIntrinsics {
  int width = 320, height = 240;
  double focal = 277;  // pixels
  double cx = 160, cy = 120;
  static CameraIntrinsics fromHorizontalFov(int width, int height, double hfov_radians);
  double verticalFov() const;
};

// Maps homogeneous pixel coordinates (u, v, 1) to the world direction of the pixel's ray,
// scaled so that its component along the optical axis is 1 (the depth of a point on the ray).
cv::Matx33d pixelRays(const Pose& pose, const CameraIntrinsics& camera);

// A plane with its own 2D coordinates in metres: the point (s, t) is origin + s * s_axis +
// t * t_axis (unit, orthogonal axes).
struct PlaneFrame {
  cv::Vec3d origin, s_axis, t_axis;
};

// Maps homogeneous pixel coordinates (u, v, 1) to homogeneous plane coordinates (s, t, 1), where
// each pixel's ray meets the plane. Pixels whose ray meets it behind the camera map to points
// too, so callers must keep only the pixels that see the plane (depth > 0).
cv::Matx33d imageToPlane(const Pose& pose, const CameraIntrinsics& camera, const PlaneFrame& plane);

// imageToPlane() of the ground (z = 0, s = x, t = y) up to scale. Only valid while the whole
// image looks below the horizon.
cv::Matx33d imageToGround(const Pose& pose, const CameraIntrinsics& camera);
cv::Matx33d groundToImage(const Pose& pose, const CameraIntrinsics& camera);

// Pixels of image `from` to pixels of image `to`, exact for the flat ground.
cv::Matx33d relativeHomography(const Pose& from, const Pose& to, const CameraIntrinsics& camera);

// The ground quadrilateral seen by the image corners, in order top-left, top-right,
// bottom-right, bottom-left (far edge first).
std::array<cv::Point2d, 4> groundFootprint(const Pose& pose, const CameraIntrinsics& camera);

double polygonArea(const std::array<cv::Point2d, 4>& quad);

// Area of ground two footprints share (square metres).
double footprintIntersection(const std::array<cv::Point2d, 4>& a,
                             const std::array<cv::Point2d, 4>& b);

// Area shared by two footprints over the area of their union (intersection over union).
double footprintOverlap(const std::array<cv::Point2d, 4>& a, const std::array<cv::Point2d, 4>& b);

}  // namespace placedb::synthetic
