#include "filter/signature.h"

#include <algorithm>
#include <string>

#include "placedb/error.h"

namespace placedb {

Signature Signature::fromWords(std::vector<WordId> words) {
  std::sort(words.begin(), words.end());
  Signature s;
  for (WordId w : words) {
    if (!s.entries_.empty() && s.entries_.back().word == w) {
      ++s.entries_.back().count;
    } else {
      s.entries_.push_back({w, 1});
    }
  }
  s.feature_count_ = static_cast<std::int64_t>(words.size());
  return s;
}

Signature Signature::fromCounts(std::vector<Entry> entries) {
  std::sort(entries.begin(), entries.end(),
            [](const Entry& a, const Entry& b) { return a.word < b.word; });
  Signature s;
  for (const Entry& e : entries) {
    if (e.count <= 0) {
      throw Error(ErrorCode::kInvalidArgument, "signature word " + std::to_string(e.word) +
                                                   " has count " + std::to_string(e.count) +
                                                   "; counts must be > 0");
    }
    if (!s.entries_.empty() && s.entries_.back().word == e.word) {
      s.entries_.back().count += e.count;
    } else {
      s.entries_.push_back(e);
    }
    s.feature_count_ += e.count;
  }
  return s;
}

std::int32_t Signature::countOf(WordId word) const {
  auto it = std::lower_bound(entries_.begin(), entries_.end(), word,
                             [](const Entry& e, WordId w) { return e.word < w; });
  return (it != entries_.end() && it->word == word) ? it->count : 0;
}

std::int64_t pairedFeatures(const Signature& a, const Signature& b) {
  const auto& ea = a.entries();
  const auto& eb = b.entries();
  std::int64_t paired = 0;
  std::size_t i = 0, j = 0;
  while (i < ea.size() && j < eb.size()) {
    if (ea[i].word < eb[j].word) {
      ++i;
    } else if (eb[j].word < ea[i].word) {
      ++j;
    } else {
      paired += std::min(ea[i].count, eb[j].count);
      ++i;
      ++j;
    }
  }
  return paired;
}

double similarity(const Signature& a, const Signature& b) {
  return similarityFromCounts(pairedFeatures(a, b), a.featureCount(), b.featureCount());
}

}  // namespace placedb
