#pragma once
// The SQLite side of what each location's rows must hold (location_rows.h): the checks a map's
// open and placedb check run on a file, and the fill of a map upgraded to schema 15.
#include "location_rows.h"

namespace placedb::storage::detail {

class Database;

// SQLite: every location's held bits against the rows there are, its tier (0-2) and its WM age
// row (its sum, an age of at least 1), and rows of place_codes and wm_entries without a location.
// One scan of locations and key lookups: what a map's open runs.
void checkLocationRows(Database& db, const FindingSink& found);

// SQLite's check of every location's links against its link_count (linkCountQuery).
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

}  // namespace placedb::storage::detail
