#include "vocabulary/slot_store.h"

#include <algorithm>
#include <stdexcept>

namespace placedb::vocab {

std::uint32_t SlotStore::add(std::int64_t id, std::int64_t created_frame, const float* descriptor) {
  std::uint32_t slot;
  if (!free_.empty()) {
    slot = free_.back();
    free_.pop_back();
    ids_[slot] = id;
    created_frames_[slot] = created_frame;
  } else {
    slot = static_cast<std::uint32_t>(ids_.size());
    if ((slot >> kChunkShift) >= chunks_.size()) {
      chunks_.emplace_back(new float[std::size_t(kChunkMask + 1) * dim_]);
    }
    ids_.push_back(id);
    created_frames_.push_back(created_frame);
  }
  std::copy(descriptor, descriptor + dim_, const_cast<float*>(data(slot)));
  return slot;
}

std::size_t SlotStore::runRoom() const {
  const std::size_t in_chunk = ids_.size() & kChunkMask;
  return std::size_t(kChunkMask + 1) - in_chunk;
}

std::uint32_t SlotStore::appendRun(std::size_t count) {
  if (!free_.empty() || count == 0 || count > runRoom())
    throw std::logic_error("SlotStore::appendRun");
  const auto first = static_cast<std::uint32_t>(ids_.size());
  if ((first >> kChunkShift) >= chunks_.size()) {
    chunks_.emplace_back(new float[std::size_t(kChunkMask + 1) * dim_]);
  }
  ids_.resize(ids_.size() + count, -1);
  created_frames_.resize(created_frames_.size() + count, -1);
  return first;
}

void SlotStore::release(std::uint32_t slot) {
  ids_[slot] = -1;
  free_.push_back(slot);
}

}  // namespace placedb::vocab
