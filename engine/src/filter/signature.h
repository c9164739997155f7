#pragma once
// A location's bag of words: each word id with how many of the location's features quantised to it.
#include <cstdint>
#include <utility>
#include <vector>

namespace placedb {

using WordId = std::int64_t;
using LocationId = std::int64_t;

class Signature {
 public:
  struct Entry {
    WordId word;
    std::int32_t count;  // > 0
    bool operator==(const Entry& o) const { return word == o.word && count == o.count; }
  };

  Signature() = default;
  // One word id per feature, any order, repeats allowed.
  static Signature fromWords(std::vector<WordId> words);
  // (word, count) pairs, any order; pairs naming the same word add up; counts must be > 0.
  static Signature fromCounts(std::vector<Entry> entries);

  // Sorted by word id, one entry per distinct word.
  const std::vector<Entry>& entries() const { return entries_; }
  // |Z|: number of features, with multiplicity.
  std::int64_t featureCount() const { return feature_count_; }
  std::size_t distinctWords() const { return entries_.size(); }
  bool empty() const { return entries_.empty(); }
  std::int32_t countOf(WordId word) const;

  bool operator==(const Signature& o) const { return entries_ == o.entries_; }
  bool operator!=(const Signature& o) const { return !(*this == o); }

 private:
  std::vector<Entry> entries_;
  std::int64_t feature_count_ = 0;
};

// N_pair: a word present n times in one and m times in the other pairs min(n, m) times.
std::int64_t pairedFeatures(const Signature& a, const Signature& b);

// Eq. 5 of paper 000: N_pair / max(|Za|, |Zb|), in [0, 1]. 0 when either signature is empty
// (an empty bag shares nothing, and 0/0 must not leak a NaN into the filter).
double similarity(const Signature& a, const Signature& b);

// The same ratio from counts already known, with the same empty-case rule.
inline double similarityFromCounts(std::int64_t paired, std::int64_t size_a, std::int64_t size_b) {
  const std::int64_t denominator = size_a > size_b ? size_a : size_b;
  if (denominator <= 0) return 0.0;
  return static_cast<double>(paired) / static_cast<double>(denominator);
}

}  // namespace placedb
