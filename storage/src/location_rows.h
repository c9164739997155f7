#pragma once
// What each location's rows must hold (schema 15): the one home of locations.held and
// locations.refs_digest. Row checksums (schema 8) find a changed row; a row deleted or added with
// plain SQL leaves no sum to fail, so each location records which of its rows exist and a digest
// of its word references. The stores write both with the rows; they are checked when a map opens
// (every location's rows are there, none is added: key lookups, no BLOB read), when a location's
// signature is read (its digest), and by placedb check (all of it, for every location).
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "placedb/storage/map_check.h"

namespace placedb::storage::detail {

inline constexpr int kLocationRowsSchemaVersion = 15;

// locations.held: which of a location's rows exist besides its references.
enum HeldRow : std::int64_t {
  kHeldPlaceCode = 1,        // place_codes
  kHeldWordDescriptors = 2,  // location_word_descriptors
  kHeldKeypoints = 4,        // engine_state 'keypoint_descriptors/<id>'
  kHeldWmEntry = 8,          // wm_entries
};

using FindingSink = std::function<void(CheckFinding)>;

// What one location's row and the rows beside it say, as either backend reads them.
struct LocationRowFacts {
  std::int64_t id = 0;
  std::optional<std::int64_t> tier, held;
  bool has_digest = false;
  bool place_code = false, word_descriptors = false, keypoints = false, wm_entry = false;
  std::int64_t wm_age = 0;
  std::optional<std::int64_t> wm_checksum;
  std::int64_t session_id = 0, weight = 0;
  std::optional<std::int64_t> created_frame, checksum;
};
// Calls `found` for each problem of that location.
void judgeLocationRow(const LocationRowFacts& facts, const FindingSink& found);

// The query both backends run for LocationRowFacts, in their order: id, tier, held, whether
// refs_digest is set, whether its place code, word descriptors, keypoints and WM age rows exist,
// the age and its checksum, then the location's session, weight, creating frame and checksum.
const std::string& locationRowFactsQuery();

// Every location's links against its link_count: the query both backends run (id, link_count,
// links counted) and the wording of a mismatch ("" when none); SQLite's check is in
// sqlite/sqlite_location_rows.h. Two key lookups a location: run with the page check on a file,
// at every open on a server, and by placedb check.
const std::string& linkCountQuery();
std::string linkCountProblem(std::optional<std::int64_t> recorded, std::int64_t counted);

// "location 5 holds one (locations.held)" and the like: one wording for both backends.
std::string heldRowProblem(std::int64_t location_id, bool held, bool present);

}  // namespace placedb::storage::detail
