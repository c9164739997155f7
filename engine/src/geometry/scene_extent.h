#pragma once
// Whether a frame and a place share a scene or only an object. The epipolar check asks whether
// pairs agree beyond chance, and the same poster, newspaper stand or locker seen at two places
// agrees far beyond chance: its picture is the same. What such a closure lacks is the rest of the
// view. So the pairs that agree with a place must cover a fair part of the scene the frame sees.
//
// The frame's scene is measured, not assumed: the region of its image where its features agree
// with its own previous view (the location it merged into, or the one before it). That region
// leaves out what no view can match again (sky, blur, a textureless wall, a passing truck), so
// the same share means the same on a street, in a corridor and on a plain floor, whatever the
// camera. Both regions are convex hulls in the frame's image of the pairs that lie on planes:
// homographies fitted one after the other, each holding at least kMinPlanePairs pairs. An
// epipolar fit also takes in unrelated pairs that happen to lie near their lines (2-4 % of the
// pairs at the check's tolerance); one of them at the far side of the image would double a
// hull, while a plane's pairs agree point to point, which chance almost never does.
//
// Few pairs span less than the region they come from, and by chance: the convex hull of k points
// uniform in a rectangle covers a share X(k) of it, 0.44 of it on average for 10 points, 0.62
// for 20 (the shape does not matter: every rectangle is an affine image of the unit square, and
// affine maps keep area ratios). So the ratio of the two hulls is the share of the scene the
// place covers times the noise X(k_place) / X(k_scene). A place is refused when that ratio is too
// small for a share of a quarter: below the 5 % quantile of 0.25 X(k_place) / X(k_scene) (log X
// taken as normal, with the means and deviations of bench/quality/hull_shares.py), the
// customary level of a one-sided test. A quarter is the rule by which tools/synthetic's exact
// ground truth names two views one place (gt_min_shared: they share at least a quarter of the
// smaller view). `share` below is the largest share the pairs are consistent with at that level,
// so a place passes at geometry_min_scene_share (0.25) or more. An object a few metres away fills
// less of the frame's scene, however sharply it agrees.
#include <vector>

#include <opencv2/core.hpp>

namespace placedb {

struct GeometricResult;

// A homography fits any 4 pairs; a fifth and a sixth within its tolerance by chance happen with
// probability (pi t^2 / A)^2, below 1e-5 per model on every image size the engine takes.
constexpr int kMinPlanePairs = 6;

// Indices of the pairs a[i] <-> b[i] that lie on up to three planes: homographies fitted by
// OpenCV's RANSAC (deterministic: its generator has a fixed seed) one after the other on the
// pairs the earlier ones left, each kept when it holds at least kMinPlanePairs pairs within
// `tolerance` pixels. Ascending.
std::vector<int> planarPairs(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b,
                             double tolerance);

// Area of the convex hull of points[i] for i in `indices` (0 for fewer than 3).
double hullArea(const std::vector<cv::Point2f>& points, const std::vector<int>& indices);

struct SceneShare {
  // Whether the frame's scene could be measured: its own previous view agrees with it on at
  // least kMinPlanePairs pairs. Not after a sharp turn or a blurred frame, and not on a
  // session's first frame; then nothing can be said of the share, and it refuses nothing.
  bool measured = false;
  double share = 0;       // the largest share of the frame's scene the pairs allow, as above
  int place_pairs = 0;    // the place's pairs on planes (all its agreeing pairs when none is)
  int scene_pairs = 0;    // the frame's own view's, likewise
  double place_area = 0;  // hulls, square pixels of the frame's image
  double scene_area = 0;
};

// `place` and `own_view` are comparisons of the frame with a place and with its own previous view
// (compareGeometry: every agreeing pair, query side first; own_view may be null). `tolerance` is
// the check's agreement distance; plane pairs agree within twice it (a point must now be placed
// along its epipolar line too).
SceneShare sceneShare(const GeometricResult& place, const GeometricResult* own_view,
                      double tolerance);

}  // namespace placedb
