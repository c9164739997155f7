#pragma once
// Descriptors of the words held in RAM, addressed by slot. Storage grows in fixed chunks so that
// adding a word never copies the existing descriptors (a 256 MB reallocation would stall a frame)
// and the pointers handed out stay valid. Freed slots are reused, lowest-freed-last (a stack).
#include <cstdint>
#include <memory>
#include <vector>

namespace placedb::vocab {

class SlotStore {
 public:
  explicit SlotStore(int dim) : dim_(dim) {}

  std::uint32_t add(std::int64_t id, std::int64_t created_frame, const float* descriptor);
  void release(std::uint32_t slot);

  // Bulk loading without a staging copy: appendRun() takes `count` new slots in one chunk, so
  // their descriptors are contiguous from mutableData(first); count must be at most runRoom()
  // and no released slot may be pending. Ids and frames are set with setRecord().
  std::size_t runRoom() const;
  // Room for `slots` slots in all without moving the chunk table (readers on other threads
  // may then use data() of existing slots while runs are appended).
  void reserve(std::size_t slots) { chunks_.reserve((slots >> kChunkShift) + 1); }
  std::uint32_t appendRun(std::size_t count);
  float* mutableData(std::uint32_t slot) { return const_cast<float*>(data(slot)); }
  void setRecord(std::uint32_t slot, std::int64_t id, std::int64_t created_frame) {
    ids_[slot] = id;
    created_frames_[slot] = created_frame;
  }

  const float* data(std::uint32_t slot) const {
    return chunks_[slot >> kChunkShift].get() + std::size_t(slot & kChunkMask) * dim_;
  }
  std::int64_t id(std::uint32_t slot) const { return ids_[slot]; }
  std::int64_t createdFrame(std::uint32_t slot) const { return created_frames_[slot]; }
  std::size_t slotCount() const { return ids_.size(); }  // live and free
  int dim() const { return dim_; }

 private:
  static constexpr std::uint32_t kChunkShift = 12;
  static constexpr std::uint32_t kChunkMask = (1u << kChunkShift) - 1;

  int dim_;
  std::vector<std::unique_ptr<float[]>> chunks_;
  std::vector<std::int64_t> ids_;
  std::vector<std::int64_t> created_frames_;
  std::vector<std::uint32_t> free_;
};

}  // namespace placedb::vocab
