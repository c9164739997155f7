#include "row_checksums.h"

// Boost.CRC instead of a hand-written table: Boost is already a dependency (Serialization), and
// its crc_optimal is the reference implementation the CRC-32C parameters below come from.
#include <boost/crc.hpp>

#include <cmath>
#include <cstring>
#include <limits>
#include <vector>
#if defined(__GNUC__) && defined(__x86_64__)
#include <nmmintrin.h>
#endif

#include "placedb/storage/storage_error.h"

namespace placedb::storage::detail {

// CRC-32C (Castagnoli): the polynomial LevelDB, RocksDB and iSCSI use. SSE4.2's crc32
// instruction computes exactly this CRC, eight bytes at a time where Boost's table takes one:
// words are summed whenever they are written or read back from long-term memory, so it is used
// where the processor has it, and Boost elsewhere.
class Crc32c {
 public:
  void process_bytes(const void* data, std::size_t size) {
#if defined(__GNUC__) && defined(__x86_64__)
    if (hardware()) {
      remainder_ = hardwareUpdate(remainder_, static_cast<const unsigned char*>(data), size);
      return;
    }
#endif
    software_.process_bytes(data, size);
  }
  std::uint32_t checksum() const {
#if defined(__GNUC__) && defined(__x86_64__)
    if (hardware()) return ~remainder_;
#endif
    return software_.checksum();
  }

 private:
#if defined(__GNUC__) && defined(__x86_64__)
  static bool hardware() {
    static const bool sse42 = __builtin_cpu_supports("sse4.2");
    return sse42;
  }
  __attribute__((target("sse4.2"))) static std::uint32_t hardwareUpdate(std::uint32_t remainder,
                                                                        const unsigned char* bytes,
                                                                        std::size_t size) {
    std::uint64_t r = remainder;
    for (; size >= 8; size -= 8, bytes += 8) {
      std::uint64_t eight;
      std::memcpy(&eight, bytes, sizeof eight);  // little-endian: the bytes in order
      r = _mm_crc32_u64(r, eight);
    }
    auto r32 = static_cast<std::uint32_t>(r);
    for (; size > 0; --size, ++bytes) r32 = _mm_crc32_u8(r32, *bytes);
    return r32;
  }
  std::uint32_t remainder_ = 0xFFFFFFFF;  // reflected, before the final inversion
#endif
  boost::crc_optimal<32, 0x1EDC6F41, 0xFFFFFFFF, 0xFFFFFFFF, true, true> software_;
};

namespace {

// Integers are summed as 8 little-endian bytes, so a sum does not depend on the host.
void addInt(Crc32c& crc, std::int64_t value) {
  unsigned char bytes[8];
  const auto u = static_cast<std::uint64_t>(value);
  for (int i = 0; i < 8; ++i) bytes[i] = static_cast<unsigned char>(u >> (8 * i));
  crc.process_bytes(bytes, sizeof bytes);
}

void addDouble(Crc32c& crc, double value) {
  std::int64_t bits = 0;
  std::memcpy(&bits, &value, sizeof bits);
  addInt(crc, bits);
}

}  // namespace

std::uint32_t wordChecksum(std::int64_t id, std::optional<std::int64_t> created_frame,
                           std::int64_t descriptor_type, std::int64_t dim,
                           const std::uint8_t* descriptor, std::size_t size) {
  Crc32c crc;
  addInt(crc, id);
  addInt(crc, created_frame.value_or(-1));
  addInt(crc, descriptor_type);
  addInt(crc, dim);
  if (size) crc.process_bytes(descriptor, size);
  return crc.checksum();
}

std::uint32_t placeCodeChecksum(std::int64_t location_id, const void* code, std::size_t size) {
  Crc32c crc;
  addInt(crc, location_id);
  if (size) crc.process_bytes(code, size);
  return crc.checksum();
}

std::uint32_t locationWordDescriptorsChecksum(std::int64_t location_id, std::int64_t dim,
                                              const void* words, std::size_t size) {
  Crc32c crc;
  addInt(crc, location_id);
  addInt(crc, dim);
  if (size) crc.process_bytes(words, size);
  return crc.checksum();
}

std::string locationWordDescriptorsFault(std::int64_t location_id, std::int64_t dim,
                                         const std::uint8_t* words, std::size_t size,
                                         LocationWordDescriptors* out) {
  LocationWordDescriptors decoded;
  if (dim <= 0 || dim > std::numeric_limits<int>::max() ||
      !decoded.decode(location_id, static_cast<int>(dim), words, size))
    return "does not hold ascending words of its dimension";
  for (float value : decoded.descriptors)
    if (!std::isfinite(value)) return "holds a value that is not a finite number";
  if (out) *out = std::move(decoded);
  return "";
}

std::uint32_t stateChecksum(const std::string& key, const void* value, std::size_t size) {
  Crc32c crc;
  addInt(crc, static_cast<std::int64_t>(key.size()));
  crc.process_bytes(key.data(), key.size());
  if (size) crc.process_bytes(value, size);
  return crc.checksum();
}

std::uint32_t kdNodeChecksum(std::int64_t tree, std::int64_t node, std::int64_t left,
                             std::int64_t right, std::int64_t split_dim, double split_value) {
  Crc32c crc;
  addInt(crc, tree);
  addInt(crc, node);
  addInt(crc, left);
  addInt(crc, right);
  addInt(crc, split_dim);
  addDouble(crc, split_value);
  return crc.checksum();
}

std::uint32_t kdJournalChecksum(std::int64_t seq, const void* changes, std::size_t size) {
  Crc32c crc;
  addInt(crc, seq);
  if (size) crc.process_bytes(changes, size);
  return crc.checksum();
}

std::uint32_t settingsDigest(std::int64_t session_id, const std::string& source,
                             const std::map<std::string, std::string>& settings) {
  Crc32c crc;
  addInt(crc, session_id);
  addInt(crc, static_cast<std::int64_t>(source.size()));
  crc.process_bytes(source.data(), source.size());
  for (const auto& [key, value] : settings)
    for (const std::string* text : {&key, &value}) {
      addInt(crc, static_cast<std::int64_t>(text->size()));
      crc.process_bytes(text->data(), text->size());
    }
  return crc.checksum();
}

std::uint32_t locationChecksum(std::int64_t id, std::int64_t session_id, std::int64_t weight,
                               std::optional<std::int64_t> created_frame) {
  Crc32c crc;
  addInt(crc, id);
  addInt(crc, session_id);
  addInt(crc, weight);
  addInt(crc, created_frame.value_or(-1));
  return crc.checksum();
}

std::uint32_t wmEntryChecksum(std::int64_t location_id, std::int64_t wm_age) {
  Crc32c crc;
  addInt(crc, location_id);
  addInt(crc, wm_age);
  return crc.checksum();
}

std::uint32_t posteriorChecksum(std::int64_t location_id, double probability) {
  Crc32c crc;
  addInt(crc, location_id);
  addDouble(crc, probability);
  return crc.checksum();
}

RefsDigest::RefsDigest(std::int64_t location_id) : sum_(std::make_unique<Crc32c>()) {
  addInt(*sum_, location_id);
}
RefsDigest::RefsDigest(RefsDigest&&) noexcept = default;
RefsDigest& RefsDigest::operator=(RefsDigest&&) noexcept = default;
RefsDigest::~RefsDigest() = default;

void RefsDigest::add(std::int64_t word_id, double x, double y, double size, double angle,
                     double response) {
  addInt(*sum_, word_id);
  for (double v : {x, y, size, angle, response}) addDouble(*sum_, v);
  ++count_;
}

std::uint32_t RefsDigest::value() const {
  Crc32c crc = *sum_;  // the count ends the sum; more references may follow
  addInt(crc, count_);
  return crc.checksum();
}

std::uint32_t refsDigest(std::int64_t location_id, const std::vector<WordRef>& refs) {
  RefsDigest digest(location_id);
  for (const WordRef& r : refs) digest.add(r.word_id, r.x, r.y, r.size, r.angle, r.response);
  return digest.value();
}

std::string refValueFault(double x, double y, double size, double angle, double response) {
  // Keypoints lie inside an image of at most kMaxImageSide (16384) pixels a side; the margin
  // leaves room for detectors that place a keypoint just outside.
  constexpr double kMaxPosition = 65536;
  for (double v : {x, y, size, angle, response})
    if (!std::isfinite(v)) return "holds a keypoint value that is not a finite number";
  if (std::abs(x) > kMaxPosition || std::abs(y) > kMaxPosition)
    return "holds a keypoint position beyond any image";
  if (size < 0 || size > kMaxPosition) return "holds a keypoint size beyond any image";
  if (angle < -1 || angle > 360) return "holds a keypoint angle outside [-1, 360]";
  return "";
}

void refuseDamagedRow(const std::string& path, const std::string& table, const std::string& row,
                      const std::string& what) {
  throw StorageError(ErrorCode::kMapRefused,
                     "map " + path + " damaged: " + table + (row.empty() ? "" : " row " + row) +
                         " " + what +
                         "; nothing was written (placedb check lists every damaged row)");
}

}  // namespace placedb::storage::detail
