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
#include "memory/place_lists.h"

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

  // From `rows` codes on (0: never), search() scans an inverted file (place_lists.h) instead of
  // every code: kListRows codes a list at training, and a search probes one list in
  // kProbeShare. Its centres are trained on the codes of the `rows` lowest location ids, which
  // are the same set whenever the training happens (codes are never removed, and a writer's
  // ids only grow), so a resumed run's index is the uninterrupted run's. See probedLists().
  //
  // Why these two: by the cost model, a search reads rows/kListRows centres and about
  // 1/kProbeShare of the codes, 1,280 instead of 16,384 codes at rows = 16,384, and k-means over
  // the training codes costs 8 rounds of rows x rows/kListRows products, once. Measured on the
  // 100k-frame scale map (bench/scale/README.md, placedb_place_lists_recall), these codes have
  // little cluster structure: the nearest 1/16 of the lists hold 8 % of the codes and 64 % of
  // the exact top 5, and 99 % of it takes half the lists (58 % of the codes). Hence the
  // engine's default, place_lists_from = 0.
  // list_rows and probe_share other than these are for bench/scale/place_lists_recall only.
  void setListsFrom(std::size_t rows, std::size_t list_rows = kListRows,
                    std::size_t probe_share = kProbeShare);
  static constexpr std::size_t kListRows = 64;
  static constexpr std::size_t kProbeShare = 16;
  // The lists and the lists probed, once trained (0 before).
  std::size_t lists() const { return lists_ ? lists_->lists() : 0; }
  std::size_t probes() const;
  const PlaceLists* placeLists() const { return lists_ ? &*lists_ : nullptr; }

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
  std::size_t lists_from_ = 0, list_rows_ = kListRows, probe_share_ = kProbeShare;
  mutable std::optional<PlaceLists> lists_;  // trained by the first search from lists_from_ on

  // The lists a search scans (training them first), or none below lists_from_.
  std::vector<std::size_t> probedLists(const std::vector<std::int8_t>& code) const;

  const std::int8_t* rowData(std::size_t row) const {
    return chunks_[row / kChunkRows].get() + (row % kChunkRows) * dim_;
  }
  std::int8_t* rowData(std::size_t row) {
    return chunks_[row / kChunkRows].get() + (row % kChunkRows) * dim_;
  }

  // The byte product of `code` with every row, handed to visit(row, product) in row order.
  template <typename Visit>
  void eachProduct(const std::vector<std::int8_t>& code, Visit&& visit) const;
  // The same for the rows of the given lists, list by list.
  template <typename Visit>
  void eachListedProduct(const std::vector<std::int8_t>& code,
                         const std::vector<std::size_t>& lists, Visit&& visit) const;

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
