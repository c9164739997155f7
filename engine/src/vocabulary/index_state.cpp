// IndexState's byte form: "PVIS", format version, index settings, next word id, split log.
// Little-endian, fixed-width fields, no padding, so equal states give equal bytes.
#include <cstring>
#include <string>

#include "placedb/error.h"
#include "vocabulary/vocabulary.h"

namespace placedb::vocab {

namespace {

constexpr char kMagic[4] = {'P', 'V', 'I', 'S'};
constexpr std::uint32_t kFormatVersion = 1;
constexpr std::size_t kSplitBytes = 1 + 4 + 2 + 4;

class Writer {
 public:
  explicit Writer(std::vector<std::uint8_t>* out) : out_(out) {}
  template <typename T>
  void put(T value) {
    std::uint8_t bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));  // the supported targets are little-endian
    out_->insert(out_->end(), bytes, bytes + sizeof(T));
  }

 private:
  std::vector<std::uint8_t>* out_;
};

class Reader {
 public:
  explicit Reader(const std::vector<std::uint8_t>& in) : in_(in) {}
  template <typename T>
  T get() {
    if (remaining() < sizeof(T)) fail("truncated");
    T value;
    std::memcpy(&value, in_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return value;
  }
  std::size_t remaining() const { return in_.size() - at_; }
  [[noreturn]] static void fail(const std::string& why) {
    throw Error(ErrorCode::kInvalidArgument, "vocabulary index state: " + why);
  }

 private:
  const std::vector<std::uint8_t>& in_;
  std::size_t at_ = 0;
};

}  // namespace

std::vector<std::uint8_t> IndexState::serialize() const {
  std::vector<std::uint8_t> out;
  out.reserve(48 + splits.size() * kSplitBytes);
  Writer w(&out);
  for (char c : kMagic) w.put(c);
  w.put(kFormatVersion);
  w.put(std::int32_t(dim));
  w.put(std::int32_t(kd_trees));
  w.put(std::int32_t(leaf_size));
  w.put(seed);
  w.put(next_word_id);
  w.put(std::uint64_t(splits.size()));
  for (const SplitRecord& s : splits) {
    w.put(s.tree);
    w.put(s.node);
    w.put(s.dim);
    w.put(s.value);
  }
  return out;
}

IndexState IndexState::deserialize(const std::vector<std::uint8_t>& bytes) {
  Reader r(bytes);
  for (char c : kMagic) {
    if (r.get<char>() != c) Reader::fail("wrong magic");
  }
  const auto version = r.get<std::uint32_t>();
  if (version != kFormatVersion) Reader::fail("unsupported version " + std::to_string(version));
  IndexState s;
  s.dim = r.get<std::int32_t>();
  s.kd_trees = r.get<std::int32_t>();
  s.leaf_size = r.get<std::int32_t>();
  s.seed = r.get<std::uint64_t>();
  s.next_word_id = r.get<std::int64_t>();
  const auto count = r.get<std::uint64_t>();
  if (count > r.remaining() / kSplitBytes || r.remaining() != count * kSplitBytes) {
    Reader::fail("split count does not match the size");
  }
  s.splits.resize(count);
  for (SplitRecord& split : s.splits) {
    split.tree = r.get<std::uint8_t>();
    split.node = r.get<std::uint32_t>();
    split.dim = r.get<std::uint16_t>();
    split.value = r.get<float>();
  }
  return s;
}

bool IndexState::operator==(const IndexState& o) const {
  return dim == o.dim && kd_trees == o.kd_trees && leaf_size == o.leaf_size && seed == o.seed &&
         next_word_id == o.next_word_id && splits == o.splits;
}

}  // namespace placedb::vocab
