#include "placedb/storage/records.h"

#include <cstring>

#include "placedb/error.h"

namespace placedb::storage {

const char* toString(Tier tier) {
  switch (tier) {
    case Tier::kStm:
      return "stm";
    case Tier::kWm:
      return "wm";
    case Tier::kLtm:
      return "ltm";
  }
  return "?";
}

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "descriptor blobs are stored little-endian; add byte swapping for this platform"
#endif

WordRecord WordRecord::fromFloats(std::int64_t id, std::optional<std::int64_t> created_frame,
                                  const float* values, int dim) {
  WordRecord word;
  word.id = id;
  word.created_frame = created_frame;
  word.type = DescriptorKind::kFloat32;
  word.dim = dim;
  word.descriptor.resize(static_cast<std::size_t>(dim) * sizeof(float));
  if (dim > 0) std::memcpy(word.descriptor.data(), values, word.descriptor.size());
  return word;
}

std::vector<float> WordRecord::floats() const {
  if (type != DescriptorKind::kFloat32 || descriptor.size() != dim * sizeof(float)) {
    throw Error(ErrorCode::kInternal,
                "word " + std::to_string(id) + " does not hold " + std::to_string(dim) + " floats");
  }
  std::vector<float> values(static_cast<std::size_t>(dim));
  std::memcpy(values.data(), descriptor.data(), descriptor.size());
  return values;
}

}  // namespace placedb::storage
