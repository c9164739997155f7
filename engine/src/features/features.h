#pragma once
// What every feature extractor hands to the rest of the pipeline.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace placedb {

enum class DescriptorType : std::uint8_t {
  kFloat32 = 0,   // compared by Euclidean distance (SURF, SIFT, KAZE)
  kBinary8U = 1,  // compared by Hamming distance (ORB); the vocabulary does not support it yet
};

struct Keypoint {
  float x = 0, y = 0;  // pixels, sub-pixel
  float size = 0;      // diameter in pixels, as cv::KeyPoint
  float angle = -1;    // degrees in [0, 360), -1 when upright
  float response = 0;  // detector strength (Hessian determinant for SURF)
  int octave = 0;
};

struct Features {
  std::string extractor;  // "surf", "sift", "kaze", "orb"
  DescriptorType type = DescriptorType::kFloat32;
  int dim = 0;                      // floats (or bytes, for binary) per descriptor
  std::vector<Keypoint> keypoints;  // strongest response first
  cv::Mat descriptors;              // keypoints.size() x dim, CV_32F (or CV_8U), continuous
  cv::Size image_size;              // of the image the keypoints are in, pixels (0 x 0: unknown)
  std::size_t size() const { return keypoints.size(); }
};

}  // namespace placedb
