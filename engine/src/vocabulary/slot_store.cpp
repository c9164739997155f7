#include "vocabulary/slot_store.h"

#include <algorithm>

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

void SlotStore::release(std::uint32_t slot) {
  ids_[slot] = -1;
  free_.push_back(slot);
}

}  // namespace placedb::vocab
