// IndexState's byte form: "PVIS", format version, index settings, next word id, then the forest's
// internal nodes (version 2) or its split log (version 1, written by maps of schema 2; read only).
// Little-endian, fixed-width fields, no padding, so equal states give equal bytes.
#include <cstring>
#include <string>

#include "placedb/error.h"
#include "vocabulary/vocabulary.h"

namespace placedb::vocab {

namespace {

constexpr char kMagic[4] = {'P', 'V', 'I', 'S'};
constexpr std::uint32_t kFormatVersion = 2;
constexpr std::uint32_t kSplitLogVersion = 1;
constexpr std::size_t kSplitBytes = 1 + 4 + 2 + 4;
constexpr std::size_t kNodeBytes = 1 + 4 + 4 + 4 + 2 + 4;

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
  const std::uint8_t* position() const { return in_.data() + at_; }
  [[noreturn]] static void fail(const std::string& why) {
    throw Error(ErrorCode::kInvalidArgument, "vocabulary index state: " + why);
  }

 private:
  const std::vector<std::uint8_t>& in_;
  std::size_t at_ = 0;
};

}  // namespace

bool appendSplitRecords(const std::uint8_t* data, std::size_t size, std::vector<SplitRecord>* out) {
  if (size % kSplitBytes != 0) return false;
  out->reserve(out->size() + size / kSplitBytes);
  for (const std::uint8_t* p = data; p < data + size; p += kSplitBytes) {
    SplitRecord s;
    std::memcpy(&s.tree, p, 1);
    std::memcpy(&s.node, p + 1, 4);
    std::memcpy(&s.dim, p + 5, 2);
    std::memcpy(&s.value, p + 7, 4);
    out->push_back(s);
  }
  return true;
}

std::vector<std::uint8_t> IndexState::serialize() const {
  if (!legacy_splits.empty())
    Reader::fail("a split log is only read, to convert it; it is never written");
  std::vector<std::uint8_t> out;
  out.reserve(48 + nodes.size() * kNodeBytes);
  Writer w(&out);
  for (char c : kMagic) w.put(c);
  w.put(kFormatVersion);
  w.put(std::int32_t(dim));
  w.put(std::int32_t(kd_trees));
  w.put(std::int32_t(leaf_size));
  w.put(seed);
  w.put(next_word_id);
  w.put(std::uint64_t(nodes.size()));
  for (const ForestNode& n : nodes) {
    w.put(n.tree);
    w.put(n.node);
    w.put(n.left);
    w.put(n.right);
    w.put(n.dim);
    w.put(n.value);
  }
  return out;
}

IndexState IndexState::deserialize(const std::vector<std::uint8_t>& bytes) {
  Reader r(bytes);
  for (char c : kMagic) {
    if (r.get<char>() != c) Reader::fail("wrong magic");
  }
  const auto version = r.get<std::uint32_t>();
  if (version != kFormatVersion && version != kSplitLogVersion)
    Reader::fail("unsupported version " + std::to_string(version));
  IndexState s;
  s.dim = r.get<std::int32_t>();
  s.kd_trees = r.get<std::int32_t>();
  s.leaf_size = r.get<std::int32_t>();
  s.seed = r.get<std::uint64_t>();
  s.next_word_id = r.get<std::int64_t>();
  const auto count = r.get<std::uint64_t>();
  const std::size_t record = version == kSplitLogVersion ? kSplitBytes : kNodeBytes;
  if (count > r.remaining() / record || r.remaining() != count * record) {
    Reader::fail("record count does not match the size");
  }
  if (version == kSplitLogVersion) {
    appendSplitRecords(r.position(), r.remaining(), &s.legacy_splits);  // whole records: checked
    return s;
  }
  s.nodes.resize(count);
  for (ForestNode& n : s.nodes) {
    n.tree = r.get<std::uint8_t>();
    n.node = r.get<std::uint32_t>();
    n.left = r.get<std::uint32_t>();
    n.right = r.get<std::uint32_t>();
    n.dim = r.get<std::uint16_t>();
    n.value = r.get<float>();
  }
  return s;
}

bool IndexState::operator==(const IndexState& o) const {
  return dim == o.dim && kd_trees == o.kd_trees && leaf_size == o.leaf_size && seed == o.seed &&
         next_word_id == o.next_word_id && nodes == o.nodes && legacy_splits == o.legacy_splits;
}

}  // namespace placedb::vocab
