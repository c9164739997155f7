#include "synthetic/ground_truth.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace placedb::synthetic {
namespace {

std::uint64_t cellKey(std::int64_t cx, std::int64_t cy) {
  return (static_cast<std::uint64_t>(cx) << 32) ^ static_cast<std::uint64_t>(cy & 0xffffffff);
}

ViewRelation relateFootprints(int gap, const Pose& q_pose, const std::array<cv::Point2d, 4>& a,
                              const Pose& r_pose, const std::array<cv::Point2d, 4>& b) {
  ViewRelation out;
  out.gap = gap;
  out.heading = headingDifference(q_pose.heading, r_pose.heading);
  const double inter = footprintIntersection(a, b);
  const double area_a = polygonArea(a), area_b = polygonArea(b);
  const double uni = area_a + area_b - inter;
  out.iou = uni > 0 ? inter / uni : 0;
  out.shared = std::min(area_a, area_b) > 0 ? inter / std::min(area_a, area_b) : 0;
  return out;
}

}  // namespace

double headingDifference(double a, double b) {
  const double d = std::remainder(a - b, 2 * CV_PI);
  return std::abs(d);
}

ViewRelation relateViews(int q, const Pose& q_pose, int r, const Pose& r_pose,
                         const CameraIntrinsics& camera) {
  return relateFootprints(q - r, q_pose, groundFootprint(q_pose, camera), r_pose,
                          groundFootprint(r_pose, camera));
}

bool isRevisit(const ViewRelation& relation, const GroundTruthSettings& settings) {
  return relation.gap >= settings.min_gap && relation.shared >= settings.min_shared;
}

std::vector<std::pair<int, int>> computeRevisits(const std::vector<Pose>& poses,
                                                 const CameraIntrinsics& camera,
                                                 const GroundTruthSettings& settings) {
  const int n = static_cast<int>(poses.size());
  std::vector<std::array<cv::Point2d, 4>> footprints(n);
  std::vector<cv::Point2d> centres(n);
  std::vector<cv::Rect2d> boxes(n);
  std::vector<double> areas(n);
  double extent = 0;  // the largest distance across any footprint
  for (int i = 0; i < n; ++i) {
    footprints[i] = groundFootprint(poses[i], camera);
    centres[i] = 0.25 * (footprints[i][0] + footprints[i][1] + footprints[i][2] + footprints[i][3]);
    double min_x = 1e300, min_y = 1e300, max_x = -1e300, max_y = -1e300;
    for (const cv::Point2d& corner : footprints[i]) {
      min_x = std::min(min_x, corner.x);
      min_y = std::min(min_y, corner.y);
      max_x = std::max(max_x, corner.x);
      max_y = std::max(max_y, corner.y);
    }
    boxes[i] = cv::Rect2d(min_x, min_y, max_x - min_x, max_y - min_y);
    areas[i] = polygonArea(footprints[i]);
    for (int a = 0; a < 4; ++a) {
      for (int b = a + 1; b < 4; ++b) {
        const cv::Point2d d = footprints[i][a] - footprints[i][b];
        extent = std::max(extent, std::hypot(d.x, d.y));
      }
    }
  }
  if (n == 0) return {};
  // A footprint is convex and holds its centre, so two footprints that share any ground have
  // centres at most two extents apart: a cell of two extents and its eight neighbours hold
  // every candidate.
  const double reach = 2 * std::max(extent, 1e-6);
  const double cell = reach;
  std::unordered_map<std::uint64_t, std::vector<int>> grid;
  auto cellOf = [&](cv::Point2d p) {
    return std::make_pair(static_cast<std::int64_t>(std::floor(p.x / cell)),
                          static_cast<std::int64_t>(std::floor(p.y / cell)));
  };
  std::vector<std::pair<int, int>> pairs;
  for (int q = 0; q < n; ++q) {
    // Frames become searchable once they are old enough to be a loop for q.
    const int newly_old = q - settings.min_gap;
    if (newly_old >= 0) {
      const auto c = cellOf(centres[newly_old]);
      grid[cellKey(c.first, c.second)].push_back(newly_old);
    }
    const auto c = cellOf(centres[q]);
    const std::size_t first_of_q = pairs.size();
    for (std::int64_t dy = -1; dy <= 1; ++dy) {
      for (std::int64_t dx = -1; dx <= 1; ++dx) {
        auto found = grid.find(cellKey(c.first + dx, c.second + dy));
        if (found == grid.end()) continue;
        for (int r : found->second) {
          const cv::Point2d d = centres[q] - centres[r];
          if (d.x * d.x + d.y * d.y > reach * reach) continue;
          // The shared area is at most the boxes' shared area: a cheap, sound rejection before
          // the exact polygon clipping.
          const double smaller = std::min(areas[q], areas[r]);
          const double box_shared = (boxes[q] & boxes[r]).area();
          if (box_shared < settings.min_shared * smaller) continue;
          const ViewRelation relation =
              relateFootprints(q - r, poses[q], footprints[q], poses[r], footprints[r]);
          if (isRevisit(relation, settings)) {
            pairs.emplace_back(q, r);
          }
        }
      }
    }
    std::sort(pairs.begin() + static_cast<std::ptrdiff_t>(first_of_q), pairs.end());
  }
  return pairs;
}

}  // namespace placedb::synthetic
