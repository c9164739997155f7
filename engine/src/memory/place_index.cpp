#include "memory/place_index.h"

#include "memory/place_code.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "features/parallel_for.h"

#include "placedb/error.h"

namespace placedb {
namespace {

double norm(const std::int8_t* code, std::size_t dim) {
  return std::sqrt(double(codeDot(code, code, dim)));
}

bool better(const PlaceMatch& a, const PlaceMatch& b) {
  return a.similarity != b.similarity ? a.similarity > b.similarity : a.location < b.location;
}

}  // namespace

template <typename Visit>
void PlaceIndex::eachProduct(const std::vector<std::int8_t>& code, Visit&& visit) const {
  // A chunk of rows a task, on every thread at once: a map of 40k locations scans 10 MB of codes
  // per frame, and the scan grows with the map while nothing else of a frame does.
  const std::size_t rows = ids_.size();
  const bool encoded = rows_with_min_byte_ == 0 && withinEncodedRange(code.data(), dim_);
  thread_local std::vector<std::int32_t> products;
  products.resize(rows);
  std::int32_t* out = products.data();
  const int blocks = static_cast<int>((rows + kChunkRows - 1) / kChunkRows);
  parallelFor(blocks, threads_, [&](int b) {
    const std::size_t start = std::size_t(b) * kChunkRows;
    const std::size_t count = std::min(kChunkRows, rows - start);
    (encoded ? encodedCodeDots : codeDots)(code.data(), rowData(start), count, dim_, out + start);
  });
  for (std::size_t row = 0; row < rows; ++row) visit(row, out[row]);
}

template <typename Visit>
void PlaceIndex::eachListedProduct(const std::vector<std::int8_t>& code,
                                   const std::vector<std::size_t>& lists, Visit&& visit) const {
  // One thread: a probe reads a few thousand codes, less than handing tasks out would cost.
  const bool encoded = rows_with_min_byte_ == 0 && withinEncodedRange(code.data(), dim_);
  thread_local std::vector<std::int32_t> products;
  for (std::size_t list : lists) {
    const std::vector<std::uint32_t>& rows = lists_->rows(list);
    products.resize(rows.size());
    (encoded ? encodedCodeDots : codeDots)(code.data(), lists_->codes(list), rows.size(), dim_,
                                           products.data());
    for (std::size_t i = 0; i < rows.size(); ++i) visit(rows[i], products[i]);
  }
}

void PlaceIndex::setListsFrom(std::size_t rows, std::size_t list_rows, std::size_t probe_share) {
  lists_from_ = rows;
  list_rows_ = std::max<std::size_t>(1, list_rows);
  probe_share_ = std::max<std::size_t>(1, probe_share);
  lists_.reset();
}

std::size_t PlaceIndex::probes() const {
  return lists_ ? std::max<std::size_t>(1, lists_->lists() / probe_share_) : 0;
}

std::vector<std::size_t> PlaceIndex::probedLists(const std::vector<std::int8_t>& code) const {
  if (lists_from_ == 0 || ids_.size() < lists_from_) return {};
  if (!lists_) {
    // The codes of the lists_from_ lowest ids, by id: the same set and order whenever this runs.
    std::vector<std::uint32_t> order(ids_.size());
    for (std::size_t row = 0; row < order.size(); ++row) order[row] = std::uint32_t(row);
    std::nth_element(order.begin(), order.begin() + lists_from_ - 1, order.end(),
                     [&](std::uint32_t a, std::uint32_t b) { return ids_[a] < ids_[b]; });
    order.resize(lists_from_);
    std::sort(order.begin(), order.end(),
              [&](std::uint32_t a, std::uint32_t b) { return ids_[a] < ids_[b]; });
    std::vector<const std::int8_t*> codes;
    codes.reserve(order.size());
    for (std::uint32_t row : order) codes.push_back(rowData(row));
    // At least two lists, so that a threshold set small (tests) still skips codes.
    lists_ = PlaceLists::train(codes, dim_, std::max<std::size_t>(2, lists_from_ / list_rows_),
                               threads_);
    for (std::size_t row = 0; row < ids_.size(); ++row)
      lists_->addRow(std::uint32_t(row), rowData(row));
  }
  return lists_->nearest(code.data(), probes());
}

void offerMatch(std::vector<PlaceMatch>& best, std::size_t k, const PlaceMatch& m,
                const std::function<bool(std::int64_t)>& admit) {
  if (best.size() == k && !better(m, best.back())) return;
  if (!admit(m.location)) return;
  best.insert(std::upper_bound(best.begin(), best.end(), m, better), m);
  if (best.size() > k) best.pop_back();
}

void PlaceIndex::add(std::int64_t location, const std::vector<std::int8_t>& code) {
  if (ids_.empty()) dim_ = code.size();
  if (code.size() != dim_ || dim_ == 0)
    throw Error(ErrorCode::kInvalidArgument, "place code of location " + std::to_string(location) +
                                                 " has " + std::to_string(code.size()) +
                                                 " values, the index " + std::to_string(dim_));
  const std::uint32_t* known = row_.find(location);
  const bool added = !known;
  const std::size_t row = added ? ids_.size() : *known;
  if (added) {
    if (ids_.size() >= std::numeric_limits<std::uint32_t>::max())
      throw Error(ErrorCode::kInvalidArgument, "place codes: more locations than rows");
    row_.insert(location, static_cast<std::uint32_t>(row));
  }
  centre_.reset();
  if (sum_.size() != dim_) sum_.assign(dim_, 0);
  if (!added) {
    const std::int8_t* old = rowData(row);
    for (std::size_t d = 0; d < dim_; ++d) sum_[d] -= old[d];
    rows_with_min_byte_ -= withinEncodedRange(old, dim_) ? 0 : 1;
  }
  rows_with_min_byte_ += withinEncodedRange(code.data(), dim_) ? 0 : 1;
  for (std::size_t d = 0; d < dim_; ++d) sum_[d] += code[d];
  if (added) {
    ids_.push_back(location);
    if (row % kChunkRows == 0) chunks_.emplace_back(new std::int8_t[kChunkRows * dim_]);
    std::copy(code.begin(), code.end(), rowData(row));
    norms_.push_back(norm(code.data(), dim_));
    if (lists_) lists_->addRow(static_cast<std::uint32_t>(row), code.data());
  } else {
    std::copy(code.begin(), code.end(), rowData(row));
    norms_[row] = norm(code.data(), dim_);
    lists_.reset();  // trained again, on the codes as they now are, as a reopened map would be
  }
}

void PlaceIndex::clear() {
  dim_ = 0;
  ids_.clear();
  chunks_.clear();
  norms_.clear();
  row_ = LocationTable<std::uint32_t>();
  sum_.clear();
  rows_with_min_byte_ = 0;
  centre_.reset();
  lists_.reset();
}

const PlaceIndex::Centre& PlaceIndex::centre() const {
  if (centre_) return *centre_;
  Centre c;
  const double n = double(ids_.size());
  c.mean.resize(dim_);
  for (std::size_t d = 0; d < dim_; ++d) c.mean[d] = double(sum_[d]) / n;
  for (double m : c.mean) c.mean_norm2 += m * m;
  c.dot_mean.resize(ids_.size());
  c.centred_norm.resize(ids_.size());
  for (std::size_t row = 0; row < ids_.size(); ++row) {
    const std::int8_t* x = rowData(row);
    double dot = 0;
    for (std::size_t d = 0; d < dim_; ++d) dot += c.mean[d] * x[d];
    c.dot_mean[row] = dot;
    // |x - m|^2 = |x|^2 - 2 x.m + |m|^2; rounding can leave a hair below 0 for x = m.
    const double n2 = norms_[row] * norms_[row] - 2 * dot + c.mean_norm2;
    c.centred_norm[row] = n2 > 1e-9 ? std::sqrt(n2) : 0.0;
  }
  centre_ = std::move(c);
  return *centre_;
}

std::vector<double> PlaceIndex::centredSimilarities(const std::vector<std::int8_t>& code) const {
  std::vector<double> out(ids_.size(), 0.0);
  if (ids_.empty() || code.size() != dim_) return out;
  const Centre& c = centre();
  double q_mean = 0;
  for (std::size_t d = 0; d < dim_; ++d) q_mean += c.mean[d] * code[d];
  const double q_norm2 =
      double(codeDot(code.data(), code.data(), dim_)) - 2 * q_mean + c.mean_norm2;
  if (q_norm2 <= 1e-9) return out;
  const double q_norm = std::sqrt(q_norm2);
  // (x - m).(q - m) = x.q - q.m - x.m + |m|^2: one byte product per row, as for the cosine.
  eachProduct(code, [&](std::size_t row, std::int32_t product) {
    if (c.centred_norm[row] == 0) return;
    const double dot = double(product) - q_mean - c.dot_mean[row] + c.mean_norm2;
    out[row] = dot / (q_norm * c.centred_norm[row]);
  });
  return out;
}

double PlaceIndex::similarity(const std::vector<std::int8_t>& code, std::int64_t location) const {
  const std::uint32_t* row = row_.find(location);
  if (!row || code.size() != dim_) return 0.0;
  const double n = norm(code.data(), dim_);
  if (n == 0 || norms_[*row] == 0) return 0.0;
  const std::int8_t* stored = rowData(*row);
  return double(codeDot(stored, code.data(), dim_)) / (norms_[*row] * n);
}

std::vector<PlaceMatch> PlaceIndex::search(const std::vector<std::int8_t>& code, std::size_t k,
                                           const std::function<bool(std::int64_t)>& admit) const {
  std::vector<PlaceMatch> best;
  if (k == 0 || ids_.empty() || code.size() != dim_) return best;
  const double query_norm = norm(code.data(), dim_);
  if (query_norm == 0) return best;
  best.reserve(k + 1);
  // Each row's cosine only where it may enter the k best: its product is at least the k-th
  // cosine times the two norms, less a margin far above the rounding of either side. The
  // cosines kept are the exact expression's, and the rows' order changes nothing (ties go to the
  // smaller id), so the lists' answer is the exact scan's over the rows they hold.
  const auto offer = [&](std::size_t row, std::int32_t product) {
    if (norms_[row] == 0) return;
    if (best.size() == k) {
      const double scale = norms_[row] * query_norm;
      const double bar = best.back().similarity * scale;
      if (double(product) < bar - 1e-9 * (std::abs(bar) + scale)) return;
    }
    offerMatch(best, k, {ids_[row], double(product) / (norms_[row] * query_norm)}, admit);
  };
  if (const auto lists = probedLists(code); !lists.empty())
    eachListedProduct(code, lists, offer);
  else
    eachProduct(code, offer);
  return best;
}

}  // namespace placedb
