#pragma once
// An inverted file over the place codes (IVF, Jégou et al. 2011): the codes are split among
// coarse centres, and a search scans only the rows of the centres nearest the query. The exact
// scan of PlaceIndex reads every code each frame, so its cost grows with the map; this one reads
// the centres and about probes/lists of the codes.
//
// Why not faiss (IndexIVFFlat) or hnswlib, both in Debian: resume must decide exactly as an
// uninterrupted run. Here the centres are a pure function of fixed codes (k-means over the
// codes of the lowest location ids, which never change: a location's code is written once;
// its sums in their order, on one thread), each row's list a pure function of its code, and the
// rows scanned are ranked by the same exact int8 products and the same tie rule as the exact scan,
// so the answer depends on neither insertion order nor thread count and nothing needs storing.
// faiss's k-means runs on BLAS floats (rounding, and so assignments, follow the thread count and
// the CPU's kernels), and its lists would hold float copies of the codes (4x the 25 MB of a
// 100k-location map); an HNSW graph depends on insertion history and would have to be stored with
// the map or rebuilt in the same order at every open. bench/scale/README.md has the recall and time
// measured.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace placedb {

class PlaceLists {
 public:
  // Trains `lists` centres on `codes` (dim signed bytes each, in a fixed order: the caller's
  // is by location id) by k-means over the unit codes (x / |x|, whose distances rank as the
  // search's cosines): the centre of list i starts as code i*n/lists, then up to kIterations
  // rounds assign every code to its nearest centre and move each centre to the mean of its
  // codes, rounded to bytes. Sums run in the codes' order and ties go to the smaller list, so
  // the centres are the same for any thread count. `threads` share the assignments.
  static PlaceLists train(const std::vector<const std::int8_t*>& codes, std::size_t dim,
                          std::size_t lists, int threads);

  std::size_t lists() const { return rows_.size(); }
  // The list whose centre is nearest `code` (the largest product over the centre's norm, the
  // smaller list on ties).
  std::size_t nearest(const std::int8_t* code) const;
  // The `count` lists nearest `code`, nearest first.
  std::vector<std::size_t> nearest(const std::int8_t* code, std::size_t count) const;

  // Files the index's row `row`, whose code is `code`, under its nearest list. Each list keeps
  // its codes back to back: a search reads them as the exact scan reads its chunks, where
  // reading each row where the index keeps it cost 4x as much a code (scattered 256-byte rows
  // the prefetcher cannot follow).
  void addRow(std::uint32_t row, const std::int8_t* code);
  const std::vector<std::uint32_t>& rows(std::size_t list) const { return rows_[list]; }
  const std::int8_t* codes(std::size_t list) const { return codes_[list].data(); }

  static constexpr int kIterations = 8;

 private:
  std::size_t dim_ = 0;
  std::vector<std::int8_t> centres_;              // lists x dim, each within [-127, 127] ...
  std::vector<double> scales_;                    // ... the list's mean code times scales_[list]
  std::vector<double> half_norm2_;                // |mean|^2 / 2
  std::vector<std::vector<std::uint32_t>> rows_;  // each list's rows of the index
  std::vector<std::vector<std::int8_t>> codes_;   // and their codes, in the same order

  // x.c - |c|^2 / 2 of `code` x and every list's mean c: larger for a nearer mean.
  void scores(const std::int8_t* code, double* out) const;
  void setCentres(std::vector<std::int8_t> centres, std::vector<double> scales);
};

}  // namespace placedb
