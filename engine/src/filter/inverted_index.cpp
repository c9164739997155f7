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
    auto& list = listOf(e.word);
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
    const std::uint32_t index = slots_.find(e.word);
    if (index == WordSlots::kNone) {
      throw Error(ErrorCode::kInternal, "inverted index: word " + std::to_string(e.word) +
                                            " of location " + std::to_string(location) +
                                            " has no postings");
    }
    auto& list = lists_[index];
    auto pos = std::lower_bound(list.begin(), list.end(), location,
                                [](const Posting& p, LocationId id) { return p.location < id; });
    if (pos == list.end() || pos->location != location) {
      throw Error(ErrorCode::kInternal, "inverted index: posting of location " +
                                            std::to_string(location) + " missing for word " +
                                            std::to_string(e.word));
    }
    list.erase(pos);
    if (list.empty()) {
      dropList(e.word, index);
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
  const std::vector<Posting>* list = findList(word);
  return list ? list->size() : 0;
}

std::vector<LocationSimilarity> InvertedIndex::similarities(const Signature& query,
                                                            const CandidateFilter& accept) const {
  // Integer pair counts are order-independent, so the hash map cannot change the results.
  std::unordered_map<LocationId, std::int64_t> paired;
  for (const auto& e : query.entries()) {
    const std::vector<Posting>* list = findList(e.word);
    if (!list) continue;
    for (const Posting& p : *list) paired[p.location] += std::min(e.count, p.count);
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
      const auto& list = *findList(e.word);
      const bool all_leaving = std::all_of(list.begin(), list.end(), [&](const Posting& p) {
        return leaving.count(p.location) != 0;
      });
      if (all_leaving) freed.push_back(e.word);
    }
  }
  std::sort(freed.begin(), freed.end());
  return freed;
}

std::size_t InvertedIndex::WordSlots::home(WordId word) const {
  // Word ids are dense and consecutive: a multiplicative hash spreads runs of them.
  return static_cast<std::size_t>((static_cast<std::uint64_t>(word) * 0x9e3779b97f4a7c15ull) >>
                                  17) &
         (cells_.size() - 1);
}

std::uint32_t InvertedIndex::WordSlots::find(WordId word) const {
  if (cells_.empty()) return kNone;
  for (std::size_t i = home(word);; i = (i + 1) & (cells_.size() - 1)) {
    const Cell& c = cells_[i];
    if (c.list == kNone) return kNone;
    if (c.word == word) return c.list;
  }
}

void InvertedIndex::WordSlots::set(WordId word, std::uint32_t list) {
  if ((size_ + 1) * 2 > cells_.size()) grow();
  std::size_t i = home(word);
  while (cells_[i].list != kNone) i = (i + 1) & (cells_.size() - 1);
  cells_[i] = {word, list};
  ++size_;
}

void InvertedIndex::WordSlots::erase(WordId word) {
  const std::size_t mask = cells_.size() - 1;
  std::size_t i = home(word);
  while (cells_[i].word != word || cells_[i].list == kNone) i = (i + 1) & mask;
  // Backward shift: move later cells of the probe run into the hole when their home allows.
  for (std::size_t j = (i + 1) & mask;; j = (j + 1) & mask) {
    if (cells_[j].list == kNone) break;
    const std::size_t h = home(cells_[j].word);
    const bool between = i <= j ? (h > i && h <= j) : (h > i || h <= j);
    if (between) continue;
    cells_[i] = cells_[j];
    i = j;
  }
  cells_[i].list = kNone;
  --size_;
}

void InvertedIndex::WordSlots::grow() {
  std::vector<Cell> old;
  old.swap(cells_);
  cells_.assign(std::max<std::size_t>(64, old.size() * 2), Cell{0, kNone});
  size_ = 0;
  for (const Cell& c : old)
    if (c.list != kNone) set(c.word, c.list);
}

std::vector<InvertedIndex::Posting>& InvertedIndex::listOf(WordId word) {
  std::uint32_t index = slots_.find(word);
  if (index != WordSlots::kNone) return lists_[index];
  if (!free_lists_.empty()) {
    index = free_lists_.back();
    free_lists_.pop_back();
  } else {
    index = static_cast<std::uint32_t>(lists_.size());
    lists_.emplace_back();
  }
  slots_.set(word, index);
  return lists_[index];
}

const std::vector<InvertedIndex::Posting>* InvertedIndex::findList(WordId word) const {
  const std::uint32_t index = slots_.find(word);
  return index == WordSlots::kNone ? nullptr : &lists_[index];
}

void InvertedIndex::dropList(WordId word, std::uint32_t index) {
  lists_[index].clear();
  free_lists_.push_back(index);
  slots_.erase(word);
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
