#pragma once
// Exact loop-closure ground truth of a synthetic route.
//
// Frame q revisits frame r when
//   q - r >= min_gap (neighbours in time are not loops), and
//   the ground quadrilaterals the two images see share at least min_shared of the smaller one's
//   area, whatever the two camera headings.
// The world is a flat textured ground, so the shared area is exactly the content both images
// show. The default features are rotation invariant, so the same street driven the other way,
// or a crossing turned through from another street, shows the same texture rotated and is as
// much the same place as a drive in the same direction. The same rule lists the revisits (the
// basis of recall) and judges an accepted closure (precision): a stricter list would call a
// closure false on ground the camera has truly seen, e.g. while it drives back up to its start
// (bench/scale/README.md, "Precision: which side was wrong").
#include <utility>
#include <vector>

#include "synthetic/camera_model.h"

namespace placedb::synthetic {

struct GroundTruthSettings {
  int min_gap = 50;
  double min_shared = 0.25;  // of the smaller footprint
};

// Absolute difference of two headings, radians in [0, pi].
double headingDifference(double a, double b);

// How the views of frames q and r relate, in the terms the rule above is stated in, with the IoU
// and heading beside them: what a benchmark reports for a closure it judges.
struct ViewRelation {
  int gap = 0;         // q - r
  double iou = 0;      // footprint intersection over union
  double shared = 0;   // footprint intersection over the smaller footprint
  double heading = 0;  // radians
};
ViewRelation relateViews(int q, const Pose& q_pose, int r, const Pose& r_pose,
                         const CameraIntrinsics& camera);

// The rule above applied to one relation: the one test of "the same place" for the revisit
// list and for judging a closure.
bool isRevisit(const ViewRelation& relation, const GroundTruthSettings& settings);

// All (q, r) pairs, sorted by q then r. Candidate pairs come from a spatial hash of footprint
// centres, so the cost grows with the number of frames times the frames seen near each place,
// not with the square of the sequence length.
std::vector<std::pair<int, int>> computeRevisits(const std::vector<Pose>& poses,
                                                 const CameraIntrinsics& camera,
                                                 const GroundTruthSettings& settings);

}  // namespace placedb::synthetic
