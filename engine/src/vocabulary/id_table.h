#pragma once
// Word id -> slot. The ids live in 4096-id pages found through a small ordered map: growing never
// rehashes or copies a large table (an unordered_map of 1M words stalls a frame for tens of ms
// when it rehashes), and ids() comes out sorted for free.
//
// A page holds its ids densely (a slot per id) while many of them are in RAM, and as a sorted
// list of the ids present while few are, and goes when it holds none. The words in RAM are those
// of working memory, and once places come back from long-term memory their ids spread over the
// whole history of the map: dense pages alone would take 4 bytes for every word the map ever
// made (16 MB at 4M words on the 100k-frame scale run), while the words in RAM stay about 70k.
#include <algorithm>
#include <cstdint>
#include <map>
#include <memory>
#include <vector>

namespace placedb::vocab {

class IdTable {
 public:
  static constexpr std::uint32_t kNone = 0xffffffffu;

  std::uint32_t find(std::int64_t id) const {
    auto it = pages_.find(id >> kPageShift);
    return it == pages_.end() ? kNone : it->second.find(offsetOf(id));
  }
  // id >= 0 and not present.
  void set(std::int64_t id, std::uint32_t slot) {
    pages_[id >> kPageShift].set(offsetOf(id), slot);
    ++size_;
  }
  // id present.
  void erase(std::int64_t id) {
    auto it = pages_.find(id >> kPageShift);
    it->second.erase(offsetOf(id));
    if (it->second.count == 0) pages_.erase(it);
    --size_;
  }
  std::size_t size() const { return size_; }
  // What the pages hold in RAM, bytes (besides the ordered map's nodes).
  std::size_t heldBytes() const {
    std::size_t bytes = 0;
    for (const auto& [page_index, page] : pages_)
      bytes += page.dense ? kPageSize * sizeof(std::uint32_t)
                          : page.offsets.capacity() * sizeof(std::uint16_t) +
                                page.slots.capacity() * sizeof(std::uint32_t);
    return bytes;
  }
  std::vector<std::int64_t> ids() const {
    std::vector<std::int64_t> out;
    out.reserve(size_);
    // Not a structured binding: C++17 lambdas cannot capture one (clang refuses; the fuzz build).
    for (const auto& entry : pages_) {
      const auto first = entry.first * kPageSize;
      entry.second.forEach([&](std::uint16_t offset) { out.push_back(first + offset); });
    }
    return out;
  }

 private:
  static constexpr int kPageShift = 12;
  static constexpr std::int64_t kPageMask = (1 << kPageShift) - 1;
  static constexpr std::uint32_t kPageSize = 1u << kPageShift;
  // A sorted list takes 6 bytes an id, a dense page 4 bytes a possible id: a page turns dense
  // above a quarter full and sorted again below an eighth, so that a page near the line does not
  // turn at every word.
  static constexpr std::uint32_t kDenseAbove = kPageSize / 4;
  static constexpr std::uint32_t kSparseBelow = kPageSize / 8;

  static std::uint16_t offsetOf(std::int64_t id) {
    return static_cast<std::uint16_t>(id & kPageMask);
  }

  struct Page {
    std::unique_ptr<std::uint32_t[]> dense;  // kPageSize slots, kNone where absent; or null
    std::vector<std::uint16_t> offsets;      // otherwise: the ids present, ascending
    std::vector<std::uint32_t> slots;        // and their slots
    std::uint32_t count = 0;

    std::uint32_t find(std::uint16_t offset) const {
      if (dense) return dense[offset];
      auto at = std::lower_bound(offsets.begin(), offsets.end(), offset);
      return at != offsets.end() && *at == offset ? slots[std::size_t(at - offsets.begin())]
                                                  : kNone;
    }
    void set(std::uint16_t offset, std::uint32_t slot) {
      ++count;
      if (dense) {
        dense[offset] = slot;
        return;
      }
      auto at = std::lower_bound(offsets.begin(), offsets.end(), offset);
      slots.insert(slots.begin() + (at - offsets.begin()), slot);
      offsets.insert(at, offset);
      if (count > kDenseAbove) toDense();
    }
    void erase(std::uint16_t offset) {
      --count;
      if (dense) {
        dense[offset] = kNone;
        if (count < kSparseBelow) toSparse();
        return;
      }
      auto at = std::lower_bound(offsets.begin(), offsets.end(), offset);
      slots.erase(slots.begin() + (at - offsets.begin()));
      offsets.erase(at);
      if (offsets.capacity() > 64 && offsets.size() < offsets.capacity() / 4) {
        offsets.shrink_to_fit();
        slots.shrink_to_fit();
      }
    }
    template <typename Visit>
    void forEach(Visit&& visit) const {
      if (!dense) {
        for (std::uint16_t offset : offsets) visit(offset);
        return;
      }
      for (std::uint32_t i = 0; i < kPageSize; ++i)
        if (dense[i] != kNone) visit(static_cast<std::uint16_t>(i));
    }
    void toDense() {
      dense = std::make_unique<std::uint32_t[]>(kPageSize);
      std::fill(dense.get(), dense.get() + kPageSize, kNone);
      for (std::size_t i = 0; i < offsets.size(); ++i) dense[offsets[i]] = slots[i];
      std::vector<std::uint16_t>().swap(offsets);
      std::vector<std::uint32_t>().swap(slots);
    }
    void toSparse() {
      offsets.reserve(count);
      slots.reserve(count);
      for (std::uint32_t i = 0; i < kPageSize; ++i) {
        if (dense[i] == kNone) continue;
        offsets.push_back(static_cast<std::uint16_t>(i));
        slots.push_back(dense[i]);
      }
      dense.reset();
    }
  };

  std::map<std::int64_t, Page> pages_;
  std::size_t size_ = 0;
};

}  // namespace placedb::vocab
