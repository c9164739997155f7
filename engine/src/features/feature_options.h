#pragma once
// Settings of every feature extractor, with their documented defaults and valid ranges.
#include <string>
#include <vector>

#include "placedb/options.h"

namespace placedb {

// The settings a user can set (extractor, hessian_threshold, octaves, intervals, upright,
// max_features, min_response) default to Options (placedb/options.h), which took them from
// RTAB-Map's SURF defaults and tuned the threshold and cap on real loop-closure data.
struct FeatureOptions {
  // "surf" (ours, 64-d float), "sift" (OpenCV, 128-d float), "kaze" (OpenCV, 64-d float) or
  // "orb" (OpenCV, 32-byte binary; refused for mapping, see makeFeatureExtractor()).
  std::string extractor = toString(Options().extractor);

  // SURF: minimum determinant of the box-filter Hessian for a blob to be kept. The responses are
  // scaled exactly as OpenCV's SURF (intensities 0..255, each box normalised by its own area),
  // so a threshold here means what it means in OpenCV/RTAB-Map. Range: [0, 1e12].
  double hessian_threshold = Options().hessian_threshold;
  // SURF and KAZE: number of octaves (octaves whose filters exceed the image are skipped).
  // Range [1, 8].
  int octaves = Options().octaves;
  // SURF: scale intervals searched per octave; each octave evaluates intervals + 2 filter sizes
  // (the default 2 gives the paper's 4 filters per octave: 9, 15, 21, 27 in the first octave).
  // Same meaning as OpenCV's nOctaveLayers. Range [1, 8].
  int intervals = Options().intervals;
  // SURF: maxima whose Hessian has a principal curvature ratio above this are dropped as edges
  // (SIFT's edge test). Not in the SURF paper: box filters let oblique edges through, and this
  // raised repeatability under a 30-degree rotation from 0.50 to 0.60 on the test pairs.
  // 0 turns it off (the published detector). Range: 0 or [1, 100].
  double edge_ratio = 5.0;
  // SURF and KAZE: U-SURF (no orientation, angle -1). SIFT and ORB ignore it.
  bool upright = Options().upright;
  // Keep at most this many features, strongest response first; 0 keeps all (ORB: 0 means 1000,
  // because OpenCV's ORB needs a cap). Range [0, 1000000].
  int max_features = Options().max_features;
  // SURF: an image with at most feature_retry x this many features is searched again at twice
  // its size, and at most this many of the finer features are kept when they number at least
  // 1 / feature_retry times its own. 0 turns it off. Range [0, 1000000].
  int feature_target = Options().feature_target;
  double feature_retry = Options().feature_retry;  // Range [0, 1], 0 = off.
  // Drop features whose detector response is below this (in each detector's own units).
  // Range: [0, 1e30].
  float min_response = static_cast<float>(Options().min_response);
  // SURF: worker threads for the Hessian layers, orientations and descriptors; results do not
  // depend on it. 0 = all hardware threads. The OpenCV extractors follow cv::setNumThreads()
  // instead. Range [0, 64].
  int threads = Options().threads;

  // SIFT: OpenCV's contrastThreshold. Range (0, 1].
  double sift_contrast_threshold = 0.04;
  // KAZE: OpenCV's detector response threshold. Range (0, 1].
  double kaze_threshold = 0.001;
  // ORB: OpenCV's fastThreshold. Range [1, 255].
  int orb_fast_threshold = 20;
};

// Names accepted in FeatureOptions::extractor.
const std::vector<std::string>& knownExtractorNames();

// Throws Error(kInvalidArgument) naming the first bad setting and its valid range.
void validateFeatureOptions(const FeatureOptions& options);

// The number of worker threads `threads` stands for (0 -> hardware concurrency, at least 1).
int resolveThreadCount(int threads);

}  // namespace placedb
