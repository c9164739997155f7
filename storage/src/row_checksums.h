#pragma once
// One home for the checksums stored beside the map's BLOBs and resume state (schema 8).
//
// SQLite's own checks (quick_check, integrity_check) see pages, records and indexes, not the bytes
// inside a BLOB: a flipped bit in a word's descriptor, or a descriptor copied onto another word,
// is a well-formed record. Every row that holds a BLOB or resume state therefore carries a
// CRC-32C of its key and payload, written with the row and compared when the row is read, so that
// damage is refused (exit 4 naming the row) instead of silently changing every later decision.
// The key is part of the sum so that a payload moved to another row does not pass either.
// kd_nodes rows hold numbers, not BLOBs, but a deleted row is as silent as a changed one: the
// number of rows is kept in engine_state (kKdNodeRowsKey) and compared when the forest loads.
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "placedb/storage/records.h"

namespace placedb::storage::detail {

// engine_state key (owned by storage) holding the row count of kd_nodes, as decimal text.
inline constexpr const char* kKdNodeRowsKey = "storage.kd_nodes.rows";

// The first schema version whose rows carry checksums.
inline constexpr int kChecksumSchemaVersion = 8;

std::uint32_t wordChecksum(std::int64_t id, std::optional<std::int64_t> created_frame,
                           std::int64_t descriptor_type, std::int64_t dim,
                           const std::uint8_t* descriptor, std::size_t size);
std::uint32_t placeCodeChecksum(std::int64_t location_id, const void* code, std::size_t size);
std::uint32_t locationWordDescriptorsChecksum(std::int64_t location_id, std::int64_t dim,
                                              const void* words, std::size_t size);
std::uint32_t stateChecksum(const std::string& key, const void* value, std::size_t size);
std::uint32_t kdNodeChecksum(std::int64_t tree, std::int64_t node, std::int64_t left,
                             std::int64_t right, std::int64_t split_dim, double split_value);
// A kd_node_journal row (schema 20): its seq, then its bytes.
std::uint32_t kdJournalChecksum(std::int64_t seq, const void* changes, std::size_t size);

// Resume rows without a BLOB that the engine reads back (schema 15): a WM age, a posterior
// probability.
std::uint32_t wmEntryChecksum(std::int64_t location_id, std::int64_t wm_age);
std::uint32_t posteriorChecksum(std::int64_t location_id, double probability);

// What a session runs over (schema 15, sessions.settings_digest): its id, its source, then every
// key and value of its settings rows, by key; each text as its length and its bytes.
std::uint32_t settingsDigest(std::int64_t session_id, const std::string& source,
                             const std::map<std::string, std::string>& settings);

// A location's row (schema 15, locations.checksum): its id, session, weight and creating frame
// (-1 for none). Its tier is the counters' to check, its held bits and digest are checked
// against the rows they describe.
std::uint32_t locationChecksum(std::int64_t id, std::int64_t session_id, std::int64_t weight,
                               std::optional<std::int64_t> created_frame);

// The digest of a location's word references (schema 15, locations.refs_digest), so that a
// reference deleted or added is found as a changed one is: its id, then every reference in
// ordinal order (word id, then x, y, size, angle and response as the REALs stored), then their
// number. Summed row by row as they are written or read: every keypoint load of a candidate
// reads a location's references through it.
class Crc32c;
class RefsDigest {
 public:
  explicit RefsDigest(std::int64_t location_id);
  RefsDigest(RefsDigest&&) noexcept;
  RefsDigest& operator=(RefsDigest&&) noexcept;
  ~RefsDigest();
  void add(std::int64_t word_id, double x, double y, double size, double angle, double response);
  std::uint32_t value() const;
  std::int64_t count() const { return count_; }

 private:
  std::unique_ptr<Crc32c> sum_;  // of the id and the references so far
  std::int64_t count_ = 0;
};
std::uint32_t refsDigest(std::int64_t location_id, const std::vector<WordRef>& refs);

// What is wrong with a reference's keypoint, or "" (a value no detector gives: not finite, a
// position or size beyond any image placedb takes, an angle outside [-1, 360]).
std::string refValueFault(double x, double y, double size, double angle, double response);

// What is wrong with a location_word_descriptors row's words beyond its checksum, or "" when they
// decode to ascending words of `dim` finite values (then into `out`, when given).
std::string locationWordDescriptorsFault(std::int64_t location_id, std::int64_t dim,
                                         const std::uint8_t* words, std::size_t size,
                                         LocationWordDescriptors* out = nullptr);

// "map P damaged: TABLE row ROW fails its checksum (...)": one wording for every reader.
[[noreturn]] void refuseDamagedRow(const std::string& path, const std::string& table,
                                   const std::string& row, const std::string& what);

}  // namespace placedb::storage::detail
