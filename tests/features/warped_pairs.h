#pragma once
// Test image pairs with a known geometric relation, and the repeatability / matching-precision
// measures computed with it.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "features/features.h"

namespace placedb::testing {

struct WarpedPair {
  std::string transform;  // "rot30", "scale0.5", "blur", ...
  cv::Mat warped;         // the second image
  cv::Matx23d to_warped;  // maps a point of the first image into the second
  // CV_32F, size of `warped`: distance to the nearest pixel that does not show the first image
  // (or to the image border). A feature counts only when its whole filter support fits.
  cv::Mat inside_distance;
  double scale = 1.0;  // size factor first -> second
};

// Rotation by `degrees` (counter-clockwise on screen, as cv::getRotationMatrix2D) and scaling,
// on a canvas that holds the whole result.
WarpedPair rotateAndScale(const cv::Mat& grey, double degrees, double scale,
                          const std::string& label);
// Same geometry, changed pixels.
WarpedPair gaussianBlur(const cv::Mat& grey, double sigma);
WarpedPair gaussianNoise(const cv::Mat& grey, double sigma, unsigned seed);
WarpedPair brightnessShift(const cv::Mat& grey, double offset);

// The standard set used by the repeatability test: rotations 30 and 90 degrees, scales 0.5 and
// 2, blur, noise and a brightness shift.
std::vector<WarpedPair> standardPairs(const cv::Mat& grey);

struct PairScore {
  int first_in_common = 0;   // first-image features whose point lands in the second image
  int second_in_common = 0;  // second-image features inside the common region
  double repeatability = 0;  // repeated first-image features / min(of the two counts above)
  double precision = 0;      // correct nearest-neighbour matches / first_in_common
  int correct_matches = 0;
};

// Features count as common when their support (radius size / 2) lies in both images.
// A feature is repeated when a second-image feature lies within `tolerance` pixels (times the
// scale when enlarging) of its mapped point with a size within a factor 1.5 of the mapped size.
// A nearest-neighbour match (Euclidean) is correct when it lies within the same tolerance.
PairScore scorePair(const Features& first, const Features& second, const WarpedPair& pair,
                    double tolerance = 2.5);

}  // namespace placedb::testing
