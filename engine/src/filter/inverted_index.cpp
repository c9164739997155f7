#include "filter/inverted_index.h"

#include <algorithm>
#include <string>
#include <unordered_set>

#include "placedb/error.h"

namespace placedb {

WordChanges InvertedIndex::add(LocationId location, const Signature& signature) {
  if (signatures_.count(location) != 0) {
    throw Error(ErrorCode::kInvalidArgument,
                "inverted index: location " + std::to_string(location) + " is already indexed");
  }
  WordChanges changes;
  for (const auto& e : signature.entries()) {
    auto& list = postings_[e.word];
    if (list.empty()) changes.referenced.push_back(e.word);
    // Kept sorted by location: new locations have the largest ids, so this is nearly always an
    // append; a location retrieved from LTM lands in the middle.
    auto pos = std::lower_bound(list.begin(), list.end(), location,
                                [](const Posting& p, LocationId id) { return p.location < id; });
    list.insert(pos, {location, e.count});
  }
  signatures_.emplace(location, signature);
  return changes;  // entries are sorted by word, so the list is too
}

WordChanges InvertedIndex::remove(LocationId location) {
  auto found = signatures_.find(location);
  if (found == signatures_.end()) {
    throw Error(ErrorCode::kInvalidArgument,
                "inverted index: location " + std::to_string(location) + " is not indexed");
  }
  WordChanges changes;
  for (const auto& e : found->second.entries()) {
    auto word_it = postings_.find(e.word);
    if (word_it == postings_.end()) {
      throw Error(ErrorCode::kInternal, "inverted index: word " + std::to_string(e.word) +
                                            " of location " + std::to_string(location) +
                                            " has no postings");
    }
    auto& list = word_it->second;
    auto pos = std::lower_bound(list.begin(), list.end(), location,
                                [](const Posting& p, LocationId id) { return p.location < id; });
    if (pos == list.end() || pos->location != location) {
      throw Error(ErrorCode::kInternal, "inverted index: posting of location " +
                                            std::to_string(location) + " missing for word " +
                                            std::to_string(e.word));
    }
    list.erase(pos);
    if (list.empty()) {
      postings_.erase(word_it);
      changes.unreferenced.push_back(e.word);
    }
  }
  signatures_.erase(found);
  return changes;
}

WordChanges InvertedIndex::replace(LocationId location, const Signature& signature) {
  WordChanges removed = remove(location);
  WordChanges added = add(location, signature);
  // A word dropped then re-added by the same swap never left the index.
  WordChanges net;
  std::set_difference(removed.unreferenced.begin(), removed.unreferenced.end(),
                      added.referenced.begin(), added.referenced.end(),
                      std::back_inserter(net.unreferenced));
  std::set_difference(added.referenced.begin(), added.referenced.end(),
                      removed.unreferenced.begin(), removed.unreferenced.end(),
                      std::back_inserter(net.referenced));
  return net;
}

const Signature& InvertedIndex::signatureOf(LocationId location) const {
  auto found = signatures_.find(location);
  if (found == signatures_.end()) {
    throw Error(ErrorCode::kInvalidArgument,
                "inverted index: location " + std::to_string(location) + " is not indexed");
  }
  return found->second;
}

std::size_t InvertedIndex::referenceCount(WordId word) const {
  auto it = postings_.find(word);
  return it == postings_.end() ? 0 : it->second.size();
}

std::vector<LocationSimilarity> InvertedIndex::similarities(const Signature& query,
                                                            const CandidateFilter& accept) const {
  // Integer pair counts are order-independent, so the hash map cannot change the results.
  std::unordered_map<LocationId, std::int64_t> paired;
  for (const auto& e : query.entries()) {
    auto word_it = postings_.find(e.word);
    if (word_it == postings_.end()) continue;
    for (const Posting& p : word_it->second) paired[p.location] += std::min(e.count, p.count);
  }
  std::vector<LocationSimilarity> out;
  out.reserve(paired.size());
  for (const auto& [location, n_pair] : paired) {
    if (accept && !accept(location)) continue;  // consulted once per location touched
    const std::int64_t size = signatures_.at(location).featureCount();
    out.push_back({location, similarityFromCounts(n_pair, query.featureCount(), size), n_pair});
  }
  std::sort(out.begin(), out.end(), [](const LocationSimilarity& a, const LocationSimilarity& b) {
    return a.location < b.location;
  });
  return out;
}

std::vector<WordId> InvertedIndex::wordsFreedByRemoving(
    const std::vector<LocationId>& locations) const {
  std::unordered_set<LocationId> leaving(locations.begin(), locations.end());
  std::vector<WordId> freed;
  std::unordered_set<WordId> seen;
  for (LocationId location : leaving) {
    for (const auto& e : signatureOf(location).entries()) {
      if (!seen.insert(e.word).second) continue;
      const auto& list = postings_.at(e.word);
      const bool all_leaving = std::all_of(list.begin(), list.end(), [&](const Posting& p) {
        return leaving.count(p.location) != 0;
      });
      if (all_leaving) freed.push_back(e.word);
    }
  }
  std::sort(freed.begin(), freed.end());
  return freed;
}

std::size_t FreedWordCounter::setAside(LocationId location) {
  const Signature& signature = index_.signatureOf(location);
  if (!aside_.emplace(location, true).second) return 0;
  std::size_t newly_freed = 0;
  for (const auto& e : signature.entries()) {
    auto it = remaining_.find(e.word);
    if (it == remaining_.end())
      it = remaining_.emplace(e.word, index_.referenceCount(e.word)).first;
    if (--it->second == 0) ++newly_freed;
  }
  freed_ += newly_freed;
  return newly_freed;
}

}  // namespace placedb
