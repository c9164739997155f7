#include "placedb/storage/records.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <functional>

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

std::vector<std::uint8_t> LocationWordDescriptors::encode() const {
  const std::size_t n = word_ids.size();
  std::vector<std::uint8_t> bytes(n * (2 * sizeof(std::int64_t)) + descriptors.size() * 4);
  std::uint8_t* at = bytes.data();
  auto put = [&at](const void* data, std::size_t size) {
    if (size) std::memcpy(at, data, size);
    at += size;
  };
  put(word_ids.data(), n * sizeof(std::int64_t));
  put(created_frames.data(), n * sizeof(std::int64_t));
  put(descriptors.data(), descriptors.size() * sizeof(float));
  return bytes;
}

bool LocationWordDescriptors::decode(std::int64_t location, int dimension, const std::uint8_t* data,
                                     std::size_t size) {
  const std::size_t per_word = 2 * sizeof(std::int64_t) + std::size_t(dimension) * sizeof(float);
  if (dimension <= 0 || size % per_word != 0) return false;
  const std::size_t n = size / per_word;
  std::vector<std::int64_t> ids(n), created(n);
  std::vector<float> values(n * std::size_t(dimension));
  if (n) {
    std::memcpy(ids.data(), data, n * sizeof(std::int64_t));
    std::memcpy(created.data(), data + n * sizeof(std::int64_t), n * sizeof(std::int64_t));
    std::memcpy(values.data(), data + 2 * n * sizeof(std::int64_t), values.size() * sizeof(float));
  }
  if (std::adjacent_find(ids.begin(), ids.end(), std::greater_equal<>()) != ids.end()) return false;
  location_id = location;
  dim = dimension;
  word_ids = std::move(ids);
  created_frames = std::move(created);
  descriptors = std::move(values);
  return true;
}

std::string locationKeypointsKey(std::int64_t location_id) {
  return kLocationKeypointsKeyPrefix + std::to_string(location_id);
}

std::string locationLatestViewKey(std::int64_t location_id) {
  return kLocationLatestViewKeyPrefix + std::to_string(location_id);
}

std::optional<std::int64_t> locationOfKeypointsKey(const std::string& key) {
  const std::string prefix = kLocationKeypointsKeyPrefix;
  if (key.size() <= prefix.size() || key.compare(0, prefix.size(), prefix) != 0)
    return std::nullopt;
  std::int64_t id = 0;
  for (std::size_t i = prefix.size(); i < key.size(); ++i) {
    if (key[i] < '0' || key[i] > '9' || id > (INT64_MAX - 9) / 10) return std::nullopt;
    id = id * 10 + (key[i] - '0');
  }
  return id;
}

}  // namespace placedb::storage
