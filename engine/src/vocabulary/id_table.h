#pragma once
// Word id -> slot. Ids are mostly dense (the vocabulary hands them out in sequence), so they live
// in 4096-entry pages found through a small ordered map: growing never rehashes or copies a large
// table (an unordered_map of 1M words stalls a frame for tens of ms when it rehashes), and ids()
// comes out sorted for free.
#include <array>
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
    return it == pages_.end() ? kNone : (*it->second)[id & kPageMask];
  }
  // id >= 0 and not present.
  void set(std::int64_t id, std::uint32_t slot) {
    auto& page = pages_[id >> kPageShift];
    if (!page) {
      page = std::make_unique<Page>();
      page->fill(kNone);
    }
    (*page)[id & kPageMask] = slot;
    ++size_;
  }
  void erase(std::int64_t id) {
    auto it = pages_.find(id >> kPageShift);
    (*it->second)[id & kPageMask] = kNone;
    --size_;
  }
  std::size_t size() const { return size_; }
  std::vector<std::int64_t> ids() const {
    std::vector<std::int64_t> out;
    out.reserve(size_);
    for (const auto& [page_index, page] : pages_) {
      for (std::size_t i = 0; i < page->size(); ++i) {
        if ((*page)[i] != kNone) out.push_back((page_index << kPageShift) + std::int64_t(i));
      }
    }
    return out;
  }

 private:
  static constexpr int kPageShift = 12;
  static constexpr std::int64_t kPageMask = (1 << kPageShift) - 1;
  using Page = std::array<std::uint32_t, 1 << kPageShift>;
  std::map<std::int64_t, std::unique_ptr<Page>> pages_;
  std::size_t size_ = 0;
};

}  // namespace placedb::vocab
