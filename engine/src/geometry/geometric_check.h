#pragma once
// Epipolar verification of a loop-closure hypothesis: are the query image's features and the
// candidate location's keypoints views of one rigid scene? Look-alike places share words too,
// but their correspondences scatter instead of agreeing on one epipolar geometry.
//
// Correspondences come first from the words the frame already has: a word that occurs once in
// the query and once in the candidate pairs those two keypoints (RTAB-Map's rule). When those
// pairs do not pass, nearest-descriptor matching against the candidate's own keypoint
// descriptors (ratio test, one match per candidate keypoint) adds the pairs words missed: the
// vocabulary's words are fine enough that a true revisit of lip6_outdoor shares only ~20 unique
// words among ~260 features, while descriptor matching pairs several times more.
//
// Both sets of pairs go through one RANSAC over 7-point fundamental matrices (epipolar_fit.h:
// the most distinctive pairs sampled first, a fixed seed, and an early exit as soon as the rule
// below is met). Three rules:
//
// inliers: one model must put min_inliers pairs within max_error_px of their epipolar lines.
// 13 sits just above the 9-12 that wrong hypotheses reach by chance at 240x192; on smaller
// images with ~90 keypoints right hypotheses rarely reach it.
//
// nfa (the default): (1) an a-contrario test: the best model's number of false alarms, i.e. how
// many models this consistent unrelated pairs would give by chance given the number of pairs, the
// image's extent and the model's 7 degrees of freedom, must be at most max_nfa. It asks whether the
// pairs share one epipolar geometry at all, and adapts to the evidence: 9 of 10 pairs within
// 1 px is as telling as 20 of 80, and a small image is judged by the same rule. (2) An
// overlap: the inliers must be at least min_overlap of the smaller view's keypoints. Two
// places along one street are views of one rigid scene too (the far facades): at NFA <= 1 they
// pass (1) with a handful of pairs, and the ground truth of a loop closure is "the same
// place", not "a common geometry"; lip6 and rtabmap_samples then get false closures.
//
// either: the inliers rule, or the nfa rule at a strict max_nfa (1e-3): a few pairs agreeing
// far beyond chance (12 of 13 within a pixel on a 160x128 image) pass without the count, while
// the same-street pairs, at NFA 1e-1..1e1, do not. Not the default: on images with many pairs
// its count accepts what chance gives (13 of 37 at NFA 1e-2 over the frame's places, a false
// closure on a walk that never revisits), so one a-contrario bar judges every frame alone.
// bench/quality/README.md has the figures of all three.
//
// The distance that counts as agreement is max_error_px (keypoint localisation), but at most
// max_error_diagonal of the query image's diagonal. The inliers rule counts pairs, and under
// the null model above a pair agrees by chance with probability alpha = 2 D eps / A: at 3 px
// a 120x96 image has twice the alpha of a 240x192 one, and 13 agreeing pairs among ~100
// features are no longer rare there. A distance in proportion to the diagonal keeps alpha at
// 2 max_error_diagonal D^2 / A whatever the size (0.041 at 1 %, for 4:3 and 5:4 images), so a
// count means the same at every size; at 1 % an image of 240x192 or more keeps 3 px.
#include <cstdint>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "geometry/descriptor_match.h"
#include "placedb/options.h"

namespace placedb {

// Defaults are Options' (geometry_rule, geometry_min_inliers, geometry_max_nfa, ...).
struct GeometricCheckSettings {
  GeometryRule rule = Options().geometry_rule;
  int min_inliers = Options().geometry_min_inliers;       // inliers rule: pairs within max_error_px
  double max_nfa = Options().geometry_max_nfa;            // nfa rule: expected false alarms at most
  double min_overlap = Options().geometry_min_overlap;    // nfa rule: inliers / keypoints at least
  double max_error_px = Options().geometry_max_error_px;  // farther from the epipolar line: out
  double max_error_diagonal = Options().geometry_max_error_diagonal;  // ... or this x diagonal
  double match_ratio = Options().geometry_match_ratio;  // nearest / second-nearest distance
  // Places the frame's acceptance is chosen among (its candidates): every false alarm count is
  // multiplied by them, since a frame that tries 13 places has 13 chances to pass by chance.
  int tests = 1;
  // The inliers rule passes only where the best model's NFA x tests is at most this: a count
  // of pairs that chance gives as often is no evidence (0: the count alone, as maps made before
  // geometry_count_candidates keep).
  double count_max_nfa = 0;
  int iterations = 400;  // RANSAC samples at most, per set of correspondences
  // Off (mapping): stop as soon as the rule is met, so the inliers counted can stop there too.
  // On (ranking several candidates, as query does): no early exit, and both the word pairs and
  // the descriptor matches are fitted, so counts compare across candidates.
  bool exhaustive = false;
};

struct GeometricResult {
  int matches = 0;          // correspondences the fit ran on (word pairs, then matches)
  int inliers = 0;          // of them, consistent with the best fundamental matrix
  double log10_nfa = 1e9;   // that model's number of false alarms, log10
  int keypoints = 0;        // of the view with fewer keypoints (the overlap's base)
  bool passed = false;      // log10_nfa <= log10(max_nfa) and enough inliers
  bool from_words = false;  // the word pairs alone passed; no descriptor was compared
  // The pairs that agree with the best model (within max_error_px of its epipolar lines), or
  // with the identity when `still`: what a relative pose is measured from (relative_pose.h).
  std::vector<cv::Point2f> agreeing_query, agreeing_candidate;
  bool still = false;  // passed as pairs that did not move (a camera standing still)
  // Compared with the view of the latest frame merged into the location (latest_view.h), not
  // its first frame's: a pose measured on these pairs is in that frame's camera.
  bool latest_view = false;
};

// Code levels (descriptor_match.h) of a frame's own descriptors, rounded once per frame, and of
// float descriptors a candidate view brings without codes.
constexpr int kQueryCodeLevels = 8191;
constexpr int kCandidateCodeLevels = 127;

struct GeometricView {  // keypoints and one descriptor row per keypoint
  std::vector<cv::Point2f> points;
  cv::Mat descriptors;  // CV_32F; may be empty when `codes` are stored ones (they decode)
  std::vector<std::int64_t> words;  // each keypoint's word, -1 for none; may be empty
  // The descriptors' codes, when the caller keeps them (the check rounds them otherwise).
  std::shared_ptr<const DescriptorCodes> codes;
  cv::Size image_size;  // of the query's image: bounds the agreement distance (0 x 0: unknown)
};

// The distance that counts as agreement on an image of `image_size`: max_error_px, or
// max_error_diagonal of its diagonal when that is less.
double agreementDistance(const GeometricCheckSettings& settings, cv::Size image_size);

// Whether a is the better result by the rule's own measure (more inliers, or a lower NFA).
bool strongerThan(const GeometricResult& a, const GeometricResult& b, GeometryRule rule);

// Inliers an overlap share of `keypoints` asks for.
int minimumInliers(double overlap, int keypoints);

// The extent (width, height) of a view's keypoints: the image area correspondences fall in.
cv::Size2f keypointExtent(const std::vector<cv::Point2f>& points);

// A location's own keypoint descriptors, kept for the check at one byte per value: each row
// stores its largest magnitude as a float, then every value as a signed byte of that scale.
// The check always uses the decoded values, so a resumed run sees exactly what a straight one did.
std::vector<std::uint8_t> encodeDescriptors(const cv::Mat& descriptors);     // CV_32F rows
cv::Mat decodeDescriptors(const std::vector<std::uint8_t>& bytes, int dim);  // empty if malformed

// Deterministic (fixed-seed sampling), so a resumed run repeats every decision.
GeometricResult checkGeometry(const GeometricView& query, const GeometricView& candidate,
                              const GeometricCheckSettings& settings);

// The confidence of a comparison's fit: RANSAC's customary 0.99 (OpenCV's findFundamentalMat
// default). A fit whose best model holds 60 % of the pairs stops after 163 of its 400 draws, one
// that holds 80 % after 20.
constexpr double kComparisonConfidence = 0.99;

// How many pairs a candidate agrees on with the query, to compare places with one another
// (decision/agreeing_place.h): one fit over the ratio matches and the word pairs they miss, with
// no stop at the first pass but at kComparisonConfidence (epipolar_fit.h). Its `passed` is the
// rule's verdict on those pairs. A candidate with fewer than `at_least` pairs cannot agree on
// that many and is not fitted: its result counts every pair as agreeing, and does not pass.
// Deterministic, as checkGeometry.
GeometricResult compareGeometry(const GeometricView& query, const GeometricView& candidate,
                                const GeometricCheckSettings& settings, int at_least = 0);

}  // namespace placedb
