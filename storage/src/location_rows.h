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

class Database;

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

// SQLite: every location's held bits against the rows there are, its tier (0-2) and its WM age
// row (its sum, an age of at least 1), and rows of place_codes and wm_entries without a location.
// One scan of locations and key lookups: what a map's open runs.
void checkLocationRows(Database& db, const FindingSink& found);

// Every location's links against its link_count: the query both backends run (id, link_count,
// links counted), the wording of a mismatch ("" when none), and SQLite's check. Two key lookups a
// location: run with the page check on a file, at every open on a server, and by placedb check.
const std::string& linkCountQuery();
std::string linkCountProblem(std::optional<std::int64_t> recorded, std::int64_t counted);
void checkLinkCounts(Database& db, const FindingSink& found);

// SQLite: every session's source and settings rows against its settings_digest (a setting deleted
// would resume the session with its default, a source changed would begin a new one).
void checkSessionRows(Database& db, const FindingSink& found);

// SQLite, for placedb check: every location's word references against its refs_digest and every
// keypoint's values (a scan of word_refs), and keypoint and word-descriptor rows without a
// location.
void checkLocationRefs(Database& db, const FindingSink& found);

// SQLite, with the page check and by placedb check, on a map the engine wrote (it holds its
// counters): every frame's rows against each other, as the engine writes them (a frame with a
// location is covered by it in location_frames, and only such frames are; a good frame has its
// hypotheses row, a bad one none). A scan of frames and key lookups.
void checkFrameRows(Database& db, const FindingSink& found);

// Fills held, refs_digest and the sums of wm_entries and filter_posterior of a map upgraded to
// schema 15, from the rows it holds (inside that migration's transaction).
void fillLocationRows(Database& db);

// "location 5 holds one (locations.held)" and the like: one wording for both backends.
std::string heldRowProblem(std::int64_t location_id, bool held, bool present);

}  // namespace placedb::storage::detail
