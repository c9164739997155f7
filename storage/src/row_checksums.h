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
#include <optional>
#include <string>

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

// What is wrong with a location_word_descriptors row's words beyond its checksum, or "" when they
// decode to ascending words of `dim` finite values (then into `out`, when given).
std::string locationWordDescriptorsFault(std::int64_t location_id, std::int64_t dim,
                                         const std::uint8_t* words, std::size_t size,
                                         LocationWordDescriptors* out = nullptr);

// "map P damaged: TABLE row ROW fails its checksum (...)": one wording for every reader.
[[noreturn]] void refuseDamagedRow(const std::string& path, const std::string& table,
                                   const std::string& row, const std::string& what);

}  // namespace placedb::storage::detail
