#pragma once
// Word -> locations postings over the locations of STM and WM, so that the similarity of a query
// with every location sharing a word costs only the postings of the query's words.
#include <cstdint>
#include <functional>
#include <unordered_map>
#include <utility>
#include <vector>

#include "filter/signature.h"

namespace placedb {

// Words whose reference count crossed zero during one change: they enter or leave the kd-index.
struct WordChanges {
  std::vector<WordId> referenced;    // now used by exactly one location, before by none (sorted)
  std::vector<WordId> unreferenced;  // now used by no location (sorted)
};

struct LocationSimilarity {
  LocationId location;
  double similarity;    // eq. 5, > 0
  std::int64_t paired;  // N_pair behind it
};

class InvertedIndex {
 public:
  // Location must not be present yet (kInvalidArgument otherwise).
  WordChanges add(LocationId location, const Signature& signature);
  // Location must be present (kInvalidArgument otherwise).
  WordChanges remove(LocationId location);
  // Swap a present location's signature; words both in old and new never appear in the lists.
  WordChanges replace(LocationId location, const Signature& signature);

  bool contains(LocationId location) const { return signatures_.count(location) != 0; }
  const Signature& signatureOf(LocationId location) const;  // kInvalidArgument when absent
  std::size_t locationCount() const { return signatures_.size(); }
  // Number of distinct words referenced by at least one location.
  std::size_t wordCount() const { return slots_.size(); }
  // Locations whose signature holds the word (0 when unreferenced).
  std::size_t referenceCount(WordId word) const;
  bool isReferenced(WordId word) const { return findList(word) != nullptr; }

  // Similarity with every location sharing at least one word with the query and accepted by the
  // filter (all locations when the filter is empty). Sorted by location id. Locations sharing no
  // word have similarity 0 and are not listed.
  using CandidateFilter = std::function<bool(LocationId)>;
  std::vector<LocationSimilarity> similarities(const Signature& query,
                                               const CandidateFilter& accept = nullptr) const;

  // Words that would leave the index if all these locations were removed together (sorted).
  std::vector<WordId> wordsFreedByRemoving(const std::vector<LocationId>& locations) const;

 private:
  struct Posting {
    LocationId location;
    std::int32_t count;
  };
  // Postings per word, sorted by location; a word with no posting is erased, so the map's keys
  // are the referenced words.
  // Word -> list index, open addressing (linear probing, backward-shift erase): a transfer and a
  // retrieval drop and re-add hundreds of words a frame, which a node map pays in allocations.
  class WordSlots {
   public:
    static constexpr std::uint32_t kNone = 0xffffffffu;
    std::uint32_t find(WordId word) const;
    void set(WordId word, std::uint32_t list);  // word must be absent
    void erase(WordId word);                    // word must be present
    std::size_t size() const { return size_; }

   private:
    struct Cell {
      WordId word;
      std::uint32_t list;
    };
    std::size_t home(WordId word) const;
    void grow();
    std::vector<Cell> cells_;  // list == kNone: empty
    std::size_t size_ = 0;
  };
  std::vector<Posting>& listOf(WordId word);  // creates an empty one
  const std::vector<Posting>* findList(WordId word) const;
  void dropList(WordId word, std::uint32_t index);  // index: the word's list, found by the caller

  WordSlots slots_;
  std::vector<std::vector<Posting>> lists_;  // reused: a dropped list keeps its capacity
  std::vector<std::uint32_t> free_lists_;
  std::unordered_map<LocationId, Signature> signatures_;
};

// Counts the words that would leave the index as locations are set aside one at a time, without
// changing the index: RTAB-Map's time-triggered transfer moves locations (in transfer order)
// until as many words leave the vocabulary as the frame created. Each step costs the words of the
// location added.
class FreedWordCounter {
 public:
  explicit FreedWordCounter(const InvertedIndex& index) : index_(index) {}
  // Sets the location aside (it must be indexed; setting it aside twice counts nothing) and
  // returns how many words that freed.
  std::size_t setAside(LocationId location);
  std::size_t freed() const { return freed_; }

 private:
  const InvertedIndex& index_;
  std::unordered_map<WordId, std::size_t> remaining_;  // references left, for words touched
  std::unordered_map<LocationId, bool> aside_;
  std::size_t freed_ = 0;
};

}  // namespace placedb
