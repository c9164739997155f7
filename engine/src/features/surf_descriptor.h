#pragma once
// SURF orientation assignment and the 64-d descriptor (Bay et al., CVIU 2008, section 4).
#include <vector>

#include <opencv2/core.hpp>

#include "features/integral_image.h"

namespace placedb {

constexpr int kSurfDescriptorDim = 64;

// Haar wavelet responses of side 2 * half centred on integral-table coordinates (a[i], b[i]):
// right minus left half (rx[i]) and bottom minus top half (ry[i]), each box clamped to the
// image. Eight at a time with AVX2 where the processor has it; the same integer sums either way.
void surfHaarResponses(const IntegralImage& integral, const int* a, const int* b, int count,
                       int half, float* rx, float* ry);

// Dominant orientation in degrees [0, 360) of a blob (keypoint.size = filter side, scale
// s = 1.2 * size / 9): Haar responses of side 4s at samples s apart within radius 6s, Gaussian
// weighted (sigma 2s), summed in a sliding 60-degree window (72 positions, 5 degrees apart);
// the longest summed vector gives the angle. Angles follow image axes (y down), as OpenCV's.
float surfOrientation(const IntegralImage& integral, const cv::KeyPoint& keypoint);

// The orientation histogram's bin (0..71, 5 degrees each) of `count` Haar responses: that of
// atan2f(ry, rx) + pi in float, as written, for each; -1 for a response (0, 0), which has none.
// Only responses near a bin's edge call atan2f.
void surfOrientationBins(const float* rx, const float* ry, int count, int* bins);

// The 64-d descriptor: a 20s x 20s window turned to keypoint.angle (angle < 0: upright),
// split into 4 x 4 sub-regions of 5 x 5 samples; Haar responses of side 2s, Gaussian weighted
// (sigma 3.3s) and expressed along the window's axes, give (sum dx, sum dy, sum |dx|, sum |dy|)
// per sub-region; the whole vector is scaled to unit length (left zero on a flat patch).
void surfDescriptor(const IntegralImage& integral, const cv::KeyPoint& keypoint, float* out);

// Orientation (unless upright, which sets angle -1) and descriptor of every keypoint, spread
// over `threads` threads; `descriptors` becomes keypoints.size() x 64, CV_32F.
void describeSurfKeypoints(const IntegralImage& integral, std::vector<cv::KeyPoint>& keypoints,
                           bool upright, int threads, cv::Mat& descriptors);

}  // namespace placedb
