#pragma once
// The place codes of every location of a map, in RAM: a brute-force search over contiguous
// signed bytes (code_dim per location), which is what lets a frame find a place whatever its
// tier. At 256 bytes a location, a million locations take 256 MB and one scan of them
// 256 M byte products; see bench/quality/README.md for the measured cost.
#include <cstdint>
#include <functional>
#include <unordered_map>
#include <utility>
#include <vector>

namespace placedb {

struct PlaceMatch {
  std::int64_t location = 0;
  double similarity = 0.0;  // cosine of the two codes
};

class PlaceIndex {
 public:
  // Adds or replaces a location's code; every code of one index has the same length.
  void add(std::int64_t location, const std::vector<std::int8_t>& code);
  void clear();
  bool contains(std::int64_t location) const { return row_.count(location) != 0; }
  std::size_t size() const { return ids_.size(); }

  // The k locations most similar to `code` among those `admit` accepts, most similar first
  // (smaller id first on ties, so the answer never depends on insertion order).
  std::vector<PlaceMatch> search(const std::vector<std::int8_t>& code, std::size_t k,
                                 const std::function<bool(std::int64_t)>& admit) const;
  // The cosine of `code` and the location's code; 0 when it has none.
  double similarity(const std::vector<std::int8_t>& code, std::int64_t location) const;

 private:
  std::size_t dim_ = 0;
  std::vector<std::int64_t> ids_;
  std::vector<std::int8_t> codes_;  // ids_.size() x dim_
  std::vector<double> norms_;
  std::unordered_map<std::int64_t, std::size_t> row_;
};

}  // namespace placedb
