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
