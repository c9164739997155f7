#pragma once
// Place codes: one compact global descriptor per location, kept for every tier, so that a frame
// can be compared with locations whose words have left RAM (long-term memory).
//
// Why not the words themselves: the online vocabulary drops a word from its kd-forest when the
// last WM location that holds it moves to LTM, so a frame that revisits an LTM place is quantised
// to other (often new) words and shares almost none with the stored signature. Keeping every
// word in RAM would make memory grow with the map, which the tiers exist to prevent.
//
// The code (a VLAD vector, Jégou et al. 2010): each descriptor is assigned to the nearest of K
// coarse centres and its residual summed per centre; each centre's block is L2-normalised
// (intra-normalisation, against bursts of repeated texture), signed square roots are taken, and
// the K x dim vector is projected to `code_dim` values by a fixed random +-1 matrix (inner
// products are kept up to a small error, Johnson-Lindenstrauss), L2-normalised and stored as
// signed bytes. Comparing two codes is a dot product of code_dim bytes.
//
// The K centres come from the first location a map stores (deterministic k-means over its
// descriptors); they are kept in the map so that every later code, resumed or not, is made
// with the same ones.
#include <cstddef>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace placedb {

struct PlaceCodeSettings {
  int centres = 16;    // K coarse centres
  int code_dim = 256;  // bytes per location code
};

class PlaceCoder {
 public:
  // Trains K centres on `descriptors` (CV_32F rows; fewer rows than K repeat rows) by
  // deterministic k-means: farthest-point seeding from row 0, then Lloyd iterations.
  static PlaceCoder train(const cv::Mat& descriptors, const PlaceCodeSettings& settings);
  // Rebuilds a coder from its serialised centres; kInvalidArgument when they do not fit `dim`.
  static PlaceCoder fromBytes(const std::vector<std::uint8_t>& bytes, int dim);
  std::vector<std::uint8_t> toBytes() const;

  // The code of one image's descriptors (CV_32F, dim columns); all zeros for no descriptor.
  std::vector<std::int8_t> encode(const cv::Mat& descriptors) const;

  int dim() const { return dim_; }
  int centres() const { return centres_.rows; }
  int codeDim() const { return code_dim_; }

 private:
  PlaceCoder(cv::Mat centres, int code_dim);
  void makeProjection();
  // The nearest centre of a descriptor; `distances` holds centres() floats of scratch.
  int nearestCentreOf(const float* row, float* distances) const;

  int dim_ = 0;
  int code_dim_ = 0;
  cv::Mat centres_;                    // K x dim, CV_32F
  std::vector<float> centres_by_dim_;  // the same, dim x K
  std::vector<std::int8_t> signs_;     // (K x dim) x code_dim projection, +-1, input-major
};

// Dot product of two codes of `code_dim` bytes: exact in 32 bits for every code_dim PlaceCoder
// accepts (65536 x 127^2 < 2^31).
std::int32_t codeDot(const std::int8_t* a, const std::int8_t* b, std::size_t code_dim);

// codeDot of `query` with each of `rows` codes stored back to back, into out[0 .. rows): the
// same exact sums, with AVX2 where the CPU has it (a map's every code is scanned each frame).
void codeDots(const std::int8_t* query, const std::int8_t* codes, std::size_t rows,
              std::size_t code_dim, std::int32_t* out);

// True when no byte of the code is -128: every code encode() makes, whose bytes are rounded
// from [-127, 127], and so every code of a map.
bool withinEncodedRange(const std::int8_t* code, std::size_t code_dim);

// codeDots for a query and codes that are all withinEncodedRange: the same exact sums, twice the
// bytes per multiply. |q| times c with q's sign, two products summed in 16 bits, cannot overflow
// there (2 x 127 x 127 < 2^15), and -c is a byte for every such c.
void encodedCodeDots(const std::int8_t* query, const std::int8_t* codes, std::size_t rows,
                     std::size_t code_dim, std::int32_t* out);

// Cosine similarity of two codes of the same length, in [-1, 1]; 0 when either is all zeros.
double codeSimilarity(const std::int8_t* a, const std::int8_t* b, int code_dim);

}  // namespace placedb
