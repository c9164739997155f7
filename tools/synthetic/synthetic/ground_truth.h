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
  double min_shared = 0.25;                   // for sharesGround() only
};

// Absolute difference of two headings, radians in [0, pi].
double headingDifference(double a, double b);

// How the views of frames q and r relate, in the terms the rule above is stated in: what a
// benchmark reports for a closure the ground truth does not list.
struct ViewRelation {
  int gap = 0;         // q - r
  double iou = 0;      // footprint intersection over union
  double shared = 0;   // footprint intersection over the smaller footprint
  double heading = 0;  // radians
};
ViewRelation relateViews(int q, const Pose& q_pose, int r, const Pose& r_pose,
                         const CameraIntrinsics& camera);

// The rule above applied to one relation.
bool isRevisit(const ViewRelation& relation, const GroundTruthSettings& settings);

// Whether an accepted loop closure of q onto r is right: r is at least min_gap frames old and
// the two images show a common patch of ground covering at least min_shared of the smaller
// footprint, whatever the headings. The revisit rule above is what an engine should be expected
// to find (alike views); this one is what it may claim. The ground is flat and the default
// features are rotation invariant, so the same street driven the other way, or a crossing
// turned through in another direction, shows the same texture rotated, and a closure verified
// on it names a place the camera has truly been. Too strict a judge here would count those as
// false (bench/scale/README.md, "Precision: which side was wrong").
bool sharesGround(const ViewRelation& relation, const GroundTruthSettings& settings);

// All (q, r) pairs, sorted by q then r. Candidate pairs come from a spatial hash of footprint
// centres, so the cost grows with the number of frames times the frames seen near each place,
// not with the square of the sequence length.
std::vector<std::pair<int, int>> computeRevisits(const std::vector<Pose>& poses,
                                                 const CameraIntrinsics& camera,
                                                 const GroundTruthSettings& settings);

}  // namespace placedb::synthetic
