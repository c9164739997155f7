#pragma once
// The place codes of every location of a map, in RAM: a brute-force search over contiguous
// signed bytes (code_dim per location), which is what lets a frame find a place whatever its
// tier. At 256 bytes a location, a million locations take 256 MB and one scan of them
// 256 M byte products; see bench/quality/README.md for the measured cost.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "memory/location_table.h"

namespace placedb {

struct PlaceMatch {
  std::int64_t location = 0;
  double similarity = 0.0;  // cosine of the two codes
};

// Offers m to `best`, the k best so far (most similar first, the smaller id first on ties):
// kept when it ranks among them and `admit` accepts it. `admit` is asked only then, since on a
// large map the caller's test (a tier lookup) costs more than a comparison.
void offerMatch(std::vector<PlaceMatch>& best, std::size_t k, const PlaceMatch& m,
                const std::function<bool(std::int64_t)>& admit);

class PlaceIndex {
 public:
  // Threads that share a scan of the codes (the caller's included); any count gives the same
  // answers, since each thread only fills its own rows' products.
  void setThreads(int threads) { threads_ = threads; }

  // Adds or replaces a location's code; every code of one index has the same length.
  void add(std::int64_t location, const std::vector<std::int8_t>& code);
  void clear();
  bool contains(std::int64_t location) const { return row_.contains(location); }
  std::size_t size() const { return ids_.size(); }

  // The k locations most similar to `code` among those `admit` accepts, most similar first
  // (smaller id first on ties, so the answer never depends on insertion order).
  std::vector<PlaceMatch> search(const std::vector<std::int8_t>& code, std::size_t k,
                                 const std::function<bool(std::int64_t)>& admit) const;
  // The cosine of `code` and the location's code; 0 when it has none.
  double similarity(const std::vector<std::int8_t>& code, std::int64_t location) const;

  // The cosine of `code` and every location's code, both less the mean code of the index, by
  // row (0 for a code equal to the mean). Codes share a large common part, the texture of the
  // whole map: on the 100k-frame scale map two frames of one place a step apart have a cosine
  // of 0.5, below hundreds of other places (0.6-0.7), and 0.28 centred, above all but a few
  // dozen (bench/scale/README.md). Centring is the first step of whitening (Jégou and Chum
  // 2012); the mean is the index's own, so nothing is tuned to a map.
  std::vector<double> centredSimilarities(const std::vector<std::int8_t>& code) const;
  std::int64_t idAt(std::size_t row) const { return ids_[row]; }
  // The row of a location's code, or size() when it has none.
  std::size_t rowOf(std::int64_t location) const {
    const std::uint32_t* row = row_.find(location);
    return row ? *row : ids_.size();
  }

 private:
  std::size_t dim_ = 0;
  std::vector<std::int64_t> ids_;
  // The codes, kChunkRows rows a chunk: a growing map never copies them all to a larger block
  // (10 MB at 42k locations, within one frame), nor keeps up to as much again of room unused.
  static constexpr std::size_t kChunkRows = 2048;
  std::vector<std::unique_ptr<std::int8_t[]>> chunks_;
  std::vector<double> norms_;
  LocationTable<std::uint32_t> row_;    // every location's row: flat (location_table.h)
  std::vector<std::int64_t> sum_;       // of every code, dim_ values: exact whatever the order
  std::size_t rows_with_min_byte_ = 0;  // rows not withinEncodedRange (no encoder makes one)
  int threads_ = 1;

  const std::int8_t* rowData(std::size_t row) const {
    return chunks_[row / kChunkRows].get() + (row % kChunkRows) * dim_;
  }
  std::int8_t* rowData(std::size_t row) {
    return chunks_[row / kChunkRows].get() + (row % kChunkRows) * dim_;
  }

  // The byte product of `code` with every row, handed to visit(row, product) in row order.
  template <typename Visit>
  void eachProduct(const std::vector<std::int8_t>& code, Visit&& visit) const;

  // The mean code and, per row, its dot product with the mean and its centred norm: rebuilt by
  // the first centred search after a change (one pass over the codes).
  struct Centre {
    std::vector<double> mean;
    double mean_norm2 = 0;
    std::vector<double> dot_mean, centred_norm;
  };
  const Centre& centre() const;
  mutable std::optional<Centre> centre_;
};

}  // namespace placedb
