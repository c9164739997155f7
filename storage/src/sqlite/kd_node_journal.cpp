#include "sqlite/kd_node_journal.h"

#include <algorithm>
#include <cstring>
#include <iterator>

#include "sqlite/database.h"
#include "sqlite/sqlite_checksums.h"

namespace placedb::storage::detail {

namespace {

constexpr std::uint8_t kDeletion = 0;
constexpr std::uint8_t kUpsert = 1;
constexpr std::size_t kDeletionBytes = 1 + 4 + 8;
constexpr std::size_t kUpsertBytes = kDeletionBytes + 8 + 8 + 4 + 8;

template <typename T>
void put(std::vector<std::uint8_t>& out, T value) {
  std::uint8_t bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));  // the supported targets are little-endian
  out.insert(out.end(), bytes, bytes + sizeof(T));
}

template <typename T>
T get(const std::uint8_t*& p) {
  T value;
  std::memcpy(&value, p, sizeof(T));
  p += sizeof(T);
  return value;
}

}  // namespace

std::vector<std::uint8_t> packKdNodeChanges(const KdNodeChanges& changes) {
  std::vector<std::uint8_t> out;
  out.reserve(changes.deletions.size() * kDeletionBytes + changes.upserts.size() * kUpsertBytes);
  for (const auto& [tree, node] : changes.deletions) {
    put(out, kDeletion);
    put(out, std::int32_t(tree));
    put(out, node);
  }
  for (const KdNodeRecord& n : changes.upserts) {
    put(out, kUpsert);
    put(out, std::int32_t(n.tree));
    put(out, n.node);
    put(out, n.left_child);
    put(out, n.right_child);
    put(out, std::int32_t(n.split_dim));
    put(out, n.split_value);
  }
  return out;
}

bool unpackKdNodeChanges(const std::uint8_t* data, std::size_t size, KdNodeChanges* out) {
  const std::uint8_t* p = data;
  const std::uint8_t* end = data + size;
  while (p < end) {
    const std::uint8_t kind = *p;
    const std::size_t bytes = kind == kDeletion ? kDeletionBytes : kUpsertBytes;
    if ((kind != kDeletion && kind != kUpsert) || std::size_t(end - p) < bytes) return false;
    ++p;
    const int tree = get<std::int32_t>(p);
    const auto node = get<std::int64_t>(p);
    if (kind == kDeletion) {
      // Deletions precede upserts within a row (packKdNodeChanges).
      if (!out->upserts.empty()) return false;
      out->deletions.emplace_back(tree, node);
      continue;
    }
    KdNodeRecord n;
    n.tree = tree;
    n.node = node;
    n.left_child = get<std::int64_t>(p);
    n.right_child = get<std::int64_t>(p);
    n.split_dim = get<std::int32_t>(p);
    n.split_value = get<double>(p);
    out->upserts.push_back(n);
  }
  return true;
}

const char* kdNodeJournalRowProblem(const Statement& row, KdNodeChanges* out) {
  const auto [data, size] = row.columnBlobView(1);
  if (!checksumMatches(row, 2, kdJournalChecksum(row.columnInt(0), data, size)))
    return "fails its checksum";
  if (!unpackKdNodeChanges(data, size, out)) return "is not whole node changes";
  return nullptr;
}

void applyKdNodeChanges(const KdNodeChanges& changes, std::map<KdNodeKey, KdNodeRecord>* nodes) {
  for (const KdNodeKey& key : changes.deletions) nodes->erase(key);
  for (const KdNodeRecord& n : changes.upserts) (*nodes)[{n.tree, n.node}] = n;
}

void PendingKdNodes::record(std::int64_t seq, const KdNodeChanges& changes) {
  for (const KdNodeKey& key : changes.deletions) {
    KdNodeRecord n;
    n.tree = key.first;
    n.node = key.second;
    add(seq, n, true);
  }
  for (const KdNodeRecord& n : changes.upserts) add(seq, n, false);
}

void PendingKdNodes::add(std::int64_t seq, const KdNodeRecord& node, bool deleted) {
  if (needed_.empty()) needed_first_ = seq;
  if (seq - needed_first_ >= static_cast<std::int64_t>(needed_.size()))
    needed_.resize(static_cast<std::size_t>(seq - needed_first_ + 1), 0);
  needed_[static_cast<std::size_t>(seq - needed_first_)] += 1;
  max_node_ = std::max(max_node_, node.node);
  // Ids below 0 go with block 0: the journal keeps what it is given, the engine judges it.
  blocks_[node.tree][std::max<std::int64_t>(0, node.node) / kBlockNodes].push_back(
      {seq, node, deleted});
}

KdNodeChanges PendingKdNodes::takeNextSlice() {
  const std::int64_t blocks = max_node_ / kBlockNodes + 1;
  const std::int64_t width = std::max<std::int64_t>(1, (blocks + kSweepFrames - 1) / kSweepFrames);
  std::vector<Change> taken;
  for (auto& [tree, by_block] : blocks_) {
    auto take = [&](auto it) {
      taken.insert(taken.end(), it->second.begin(), it->second.end());
      return by_block.erase(it);
    };
    // Whichever is fewer: the slice's blocks, or the blocks holding pending changes.
    if (static_cast<std::size_t>(width) <= by_block.size()) {
      for (std::int64_t b = cursor_; b < cursor_ + width; ++b)
        if (auto it = by_block.find(b); it != by_block.end()) take(it);
      continue;
    }
    for (auto it = by_block.begin(); it != by_block.end();)
      it = it->first >= cursor_ && it->first < cursor_ + width ? take(it) : std::next(it);
  }
  cursor_ = cursor_ + width >= blocks ? 0 : cursor_ + width;
  // Each node's latest change, in key order: a stable sort keeps a node's changes in arrival
  // order, and the last of them wins.
  std::stable_sort(taken.begin(), taken.end(), [](const Change& a, const Change& b) {
    return std::make_pair(a.node.tree, a.node.node) < std::make_pair(b.node.tree, b.node.node);
  });
  KdNodeChanges slice;
  for (std::size_t i = 0; i < taken.size(); ++i) {
    const Change& c = taken[i];
    needed_[static_cast<std::size_t>(c.seq - needed_first_)] -= 1;
    const bool last = i + 1 == taken.size() || taken[i + 1].node.tree != c.node.tree ||
                      taken[i + 1].node.node != c.node.node;
    if (!last) continue;
    if (c.deleted)
      slice.deletions.emplace_back(c.node.tree, c.node.node);
    else
      slice.upserts.push_back(c.node);
  }
  while (!needed_.empty() && needed_.front() == 0) {
    needed_.pop_front();
    ++needed_first_;
  }
  return slice;
}

std::int64_t PendingKdNodes::oldestNeeded(std::int64_t next_seq) const {
  return needed_.empty() ? next_seq : needed_first_;
}

void PendingKdNodes::clear() {
  blocks_.clear();
  needed_.clear();
  needed_first_ = 0;
  cursor_ = 0;
  max_node_ = 0;
}

}  // namespace placedb::storage::detail
