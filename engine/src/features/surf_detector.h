#pragma once
// SURF's fast-Hessian detector (Bay et al., CVIU 2008, section 3): box-filter approximations of
// the Hessian determinant over octaves and intervals, 3x3x3 non-maximum suppression, and
// sub-pixel / sub-scale interpolation by a quadratic fit (Brown and Lowe 2002).
// Two departures from the paper, both for rotation invariance (see surf_detector.cpp): the Dxy
// weight follows the filter size instead of a constant 0.9, and edge-like maxima are dropped.
#include <vector>

#include <opencv2/core.hpp>

#include "features/integral_image.h"

namespace placedb {

struct SurfDetectorSettings {
  double hessian_threshold = 500.0;
  int octaves = 4;
  int intervals = 2;        // scales searched per octave; intervals + 2 filters are evaluated
  double edge_ratio = 5.0;  // maxima with a larger principal curvature ratio are dropped; 0: off
  int threads = 1;
};

// Side of the box filter for `layer` (0 .. intervals + 1) of `octave` (0-based), as in the paper:
// 9, 15, 21, 27 in the first octave, 15, 27, 39, 51 in the second, and so on. Octave o samples
// the image every 2^o pixels.
int surfFilterSize(int octave, int layer);

// Blob centres in pixel coordinates (pixel centres at integers), size = interpolated filter side
// (the blob's scale is 1.2 * size / 9), response = interpolated Hessian determinant, octave set,
// angle -1. Responses are scaled as OpenCV's SURF: each box of a filter is normalised by its own
// area on 0..255 intensities. The order is deterministic (octave, layer, row, column) whatever
// the thread count.
std::vector<cv::KeyPoint> detectSurfBlobs(const IntegralImage& integral,
                                          const SurfDetectorSettings& settings);

}  // namespace placedb
