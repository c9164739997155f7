#pragma once
// Exact loop-closure ground truth of a synthetic route.
//
// Frame q revisits frame r when
//   q - r >= min_gap (neighbours in time are not loops),
//   the two camera headings differ by at most max_heading, and
//   the ground quadrilaterals the two images see overlap with intersection-over-union >=
//   min_overlap.
// Since the world is a flat textured ground, the overlap is exactly the content both images
// share: with IoU >= 0.5 each image shows at least half of the other's ground (the shared area is
// at least IoU times either footprint), and the heading bound keeps the two perspectives alike,
// so the same structures appear at similar scales in both.
#include <utility>
#include <vector>

#include "synthetic/camera_model.h"

namespace placedb::synthetic {

struct GroundTruthSettings {
  int min_gap = 50;
  double min_overlap = 0.5;
  double max_heading = 30.0 * CV_PI / 180.0;  // radians
};

// All (q, r) pairs, sorted by q then r. Candidate pairs come from a spatial hash of footprint
// centres, so the cost grows with the number of frames times the frames seen near each place,
// not with the square of the sequence length.
std::vector<std::pair<int, int>> computeRevisits(const std::vector<Pose>& poses,
                                                 const CameraIntrinsics& camera,
                                                 const GroundTruthSettings& settings);

}  // namespace placedb::synthetic
