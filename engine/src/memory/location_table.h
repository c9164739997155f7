#pragma once
// Location id -> value, for what the engine keeps of every location of a map, whatever its tier.
// A map hands location ids out densely (in blocks of 1024 when several writers share it), so
// they live in pages of 1024 values found through a small ordered map: about sizeof(T) a
// location, where a node-based map takes 48-80 bytes more for each, and a map of 42k locations
// keeps every one of them in RAM for good.
#include <array>
#include <bitset>
#include <cstdint>
#include <map>
#include <memory>

namespace placedb {

template <typename T>
class LocationTable {
 public:
  const T* find(std::int64_t id) const {
    auto it = pages_.find(id >> kPageShift);
    if (it == pages_.end() || !it->second->present[offsetOf(id)]) return nullptr;
    return &it->second->values[offsetOf(id)];
  }
  T* find(std::int64_t id) {
    return const_cast<T*>(static_cast<const LocationTable&>(*this).find(id));
  }
  bool contains(std::int64_t id) const { return find(id) != nullptr; }
  // Adds `value` under `id`, which must not be present.
  T& insert(std::int64_t id, const T& value) {
    auto& page = pages_[id >> kPageShift];
    if (!page) page = std::make_unique<Page>();
    page->present.set(offsetOf(id));
    ++size_;
    return page->values[offsetOf(id)] = value;
  }
  // Removes `id`, which must be present.
  void erase(std::int64_t id) {
    auto it = pages_.find(id >> kPageShift);
    it->second->present.reset(offsetOf(id));
    it->second->values[offsetOf(id)] = T();
    if (it->second->present.none()) pages_.erase(it);
    --size_;
  }
  std::size_t size() const { return size_; }
  // visit(id, value) for every id present, ascending.
  template <typename Visit>
  void forEach(Visit&& visit) const {
    for (const auto& [page_index, page] : pages_)
      for (std::size_t i = 0; i < kPageSize; ++i)
        if (page->present[i])
          visit(page_index * std::int64_t(kPageSize) + std::int64_t(i), page->values[i]);
  }

 private:
  static constexpr int kPageShift = 10;
  static constexpr std::size_t kPageSize = std::size_t{1} << kPageShift;
  // Any int64 id is taken, negative ones too: the page index is id >> kPageShift, a shift that
  // floors, and ids are rebuilt by multiplying, since shifting a negative value left is undefined.
  static std::size_t offsetOf(std::int64_t id) { return std::size_t(id) & (kPageSize - 1); }

  struct Page {
    std::array<T, kPageSize> values{};
    std::bitset<kPageSize> present;
  };
  std::map<std::int64_t, std::unique_ptr<Page>> pages_;
  std::size_t size_ = 0;
};

}  // namespace placedb
