#pragma once
// The ratio test's nearest and second-nearest candidate descriptor of every query descriptor,
// exactly as comparing every pair in full would find them, at a fraction of the cost.
//
// Comparing a frame's ~300 descriptors with each of ~10 candidates' ~300 in full was most of
// the geometric check's time, and most of it goes to candidates that fail. Both sides are also
// kept as small integers (DescriptorCodes): a candidate's stored descriptors are int8 codes
// already (encodeDescriptors), and the query's are rounded to 14-bit codes once per frame. An
// integer dot product gives each pair's distance between the codes; how far that can be from
// the distance of the values themselves is bounded per row (the rounding, by the triangle
// inequality, plus a margin far above what float arithmetic can add). Only the pairs whose
// interval can reach one of the two smallest distances are compared in full, in ascending
// candidate order as the full loop does, so ties resolve the same way; a query row whose
// smallest possible nearest distance already fails the ratio against the largest possible
// second is not compared in full at all. The matches, distances and ratios are the full
// comparison's, bit for bit, whatever the data: only the time depends on how well the codes
// separate the distances.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace placedb {

struct DescriptorCodes {
  int rows = 0, dim = 0;
  std::vector<std::int16_t> codes;  // rows x dim; empty when only `blocked` holds them
  // The same codes laid out for the candidate side (blockCodes(), descriptor_dots.h): what
  // storedDescriptorCodes() keeps, for an even dim.
  std::vector<std::int16_t> blocked;
  std::vector<double> unit;   // per row: the value one code step stands for
  std::vector<double> norm;   // per row: length of the codes' vector (code * unit)
  std::vector<double> error;  // per row: bound on |values - codes' vector|; inf: unknown
  // Levels on each side of 0: codes run over [-levels, levels].
  int levels = 0;
  // Set when the values are exactly decodeDescriptors() of the codes (a stored location's
  // descriptors), so a row's values can be decoded on demand instead of kept as floats.
  bool stored = false;
  std::vector<float> stored_scale;  // per row, when `stored`: the row's encoded scale
};

// Rounds float rows (CV_32F) to `levels` steps per side of each row's largest magnitude.
DescriptorCodes quantiseDescriptors(const cv::Mat& descriptors, int levels);

// The codes of encodeDescriptors() bytes, without rounding (empty if malformed).
DescriptorCodes storedDescriptorCodes(const std::vector<std::uint8_t>& bytes, int dim);

// A side of the comparison: the float rows, or (for stored codes) nothing and the codes decode.
struct DescriptorSide {
  const cv::Mat* values = nullptr;  // CV_32F rows, or null/empty when codes.stored
  const DescriptorCodes* codes = nullptr;
  int rows() const;
};

struct RatioMatch {
  int query = 0, candidate = 0;
  float d1 = 0, d2 = 0;  // squared distances to the nearest and second nearest
};

// Every query row whose nearest candidate row is closer than `ratio_sq` times the second
// nearest (squared distances), in query order; both sides need 2 rows or more.
std::vector<RatioMatch> ratioMatches(const DescriptorSide& query, const DescriptorSide& candidate,
                                     float ratio_sq);

// The same by comparing every pair in full: the definition the above is held to.
std::vector<RatioMatch> ratioMatchesBruteForce(const DescriptorSide& query,
                                               const DescriptorSide& candidate, float ratio_sq);

}  // namespace placedb
