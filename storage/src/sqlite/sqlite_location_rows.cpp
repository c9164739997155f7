// The SQLite side of what each location's rows must hold (location_rows.h).
#include "sqlite/sqlite_location_rows.h"

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "placedb/storage/records.h"
#include "row_checksums.h"
#include "sqlite/database.h"
#include "sqlite/sqlite_checksums.h"

namespace placedb::storage::detail {

void checkLocationRows(Database& db, const FindingSink& found) {
  Statement s(db.handle(), locationRowFactsQuery());
  while (s.step()) {
    LocationRowFacts f;
    f.id = s.columnInt(0);
    f.tier = s.columnOptionalInt(1);
    f.held = s.columnOptionalInt(2);
    f.has_digest = s.columnInt(3) != 0;
    f.place_code = s.columnInt(4) != 0;
    f.word_descriptors = s.columnInt(5) != 0;
    f.keypoints = s.columnInt(6) != 0;
    f.wm_entry = s.columnInt(7) != 0;
    f.wm_age = s.isNull(8) ? 0 : s.columnInt(8);
    f.wm_checksum = s.columnOptionalInt(9);
    f.session_id = s.columnInt(10);
    f.weight = s.columnInt(11);
    f.created_frame = s.columnOptionalInt(12);
    f.checksum = s.columnOptionalInt(13);
    judgeLocationRow(f, found);
  }
  for (const char* table : {"place_codes", "wm_entries"}) {
    Statement orphans(db.handle(), std::string("SELECT location_id FROM ") + table +
                                       " WHERE location_id NOT IN (SELECT id FROM locations)");
    while (orphans.step())
      found({table, std::to_string(orphans.columnInt(0)),
             "belongs to no location (its locations row is missing)"});
  }
}

void checkLinkCounts(Database& db, const FindingSink& found) {
  Statement s(db.handle(), linkCountQuery());
  while (s.step()) {
    const std::string problem = linkCountProblem(s.columnOptionalInt(1), s.columnInt(2));
    if (!problem.empty())
      found({"links", "of location " + std::to_string(s.columnInt(0)), problem});
  }
}

void checkSessionRows(Database& db, const FindingSink& found) {
  std::map<std::int64_t, std::map<std::string, std::string>> settings;
  Statement read(db.handle(), "SELECT session_id, key, value FROM settings");
  while (read.step()) settings[read.columnInt(0)][read.columnText(1)] = read.columnText(2);
  Statement sessions(db.handle(), "SELECT id, source, settings_digest FROM sessions");
  while (sessions.step()) {
    const std::int64_t id = sessions.columnInt(0);
    if (!checksumMatches(sessions, 2, settingsDigest(id, sessions.columnText(1), settings[id])))
      found({"settings", "of session " + std::to_string(id),
             "do not match the session's settings_digest (a setting was deleted, added or "
             "changed, or the session's source)"});
  }
}

void checkLocationRefs(Database& db, const FindingSink& found) {
  // Both scans in location order: word_refs by its key, locations by id.
  Statement refs(db.handle(),
                 "SELECT location_id, ordinal, word_id, x, y, size, angle, response FROM word_refs "
                 "ORDER BY location_id, ordinal");
  Statement locations(db.handle(), "SELECT id, refs_digest FROM locations ORDER BY id");
  bool more_refs = refs.step();
  while (locations.step()) {
    const std::int64_t id = locations.columnInt(0);
    while (more_refs && refs.columnInt(0) < id) {
      found(
          {"word_refs",
           "(" + std::to_string(refs.columnInt(0)) + ", " + std::to_string(refs.columnInt(1)) + ")",
           "belongs to no location (its locations row is missing)"});
      more_refs = refs.step();
    }
    RefsDigest digest(id);
    for (; more_refs && refs.columnInt(0) == id; more_refs = refs.step()) {
      const std::string fault =
          refValueFault(refs.columnDouble(3), refs.columnDouble(4), refs.columnDouble(5),
                        refs.columnDouble(6), refs.columnDouble(7));
      if (!fault.empty())
        found({"word_refs",
               "(" + std::to_string(id) + ", " + std::to_string(refs.columnInt(1)) + ")", fault});
      digest.add(refs.columnInt(2), refs.columnDouble(3), refs.columnDouble(4),
                 refs.columnDouble(5), refs.columnDouble(6), refs.columnDouble(7));
    }
    if (!locations.isNull(1) && !checksumMatches(locations, 1, digest.value()))
      found({"word_refs", "of location " + std::to_string(id),
             "do not match the location's refs_digest (" + std::to_string(digest.count()) +
                 " rows: a reference was deleted, added or changed)"});
  }
  for (; more_refs; more_refs = refs.step())
    found({"word_refs",
           "(" + std::to_string(refs.columnInt(0)) + ", " + std::to_string(refs.columnInt(1)) + ")",
           "belongs to no location (its locations row is missing)"});
  // The id is read from the key: a key compared with every location's would cost their product.
  const std::string prefix = std::string(kLocationKeypointsKeyPrefix);
  Statement keypoints(db.handle(), "SELECT key FROM engine_state WHERE key >= '" + prefix +
                                       "' AND key < '" + prefix.substr(0, prefix.size() - 1) +
                                       "0' AND NOT EXISTS (SELECT 1 FROM locations l WHERE l.id = "
                                       "CAST(substr(key, " +
                                       std::to_string(prefix.size() + 1) + ") AS INTEGER))");
  while (keypoints.step())
    found({"engine_state", "'" + keypoints.columnText(0) + "'",
           "belongs to no location (its locations row is missing)"});
}

void checkFrameRows(Database& db, const FindingSink& found) {
  if (db.queryInt("SELECT count(*) FROM engine_state WHERE key = 'engine.counters'") == 0) return;
  const auto pair = [](std::int64_t a, std::int64_t b) {
    return "(" + std::to_string(a) + ", " + std::to_string(b) + ")";
  };
  Statement uncovered(db.handle(),
                      "SELECT f.location_id, f.id FROM frames f WHERE f.location_id IS NOT NULL "
                      "AND NOT EXISTS (SELECT 1 FROM location_frames c WHERE c.location_id = "
                      "f.location_id AND c.frame_id = f.id)");
  while (uncovered.step())
    found({"location_frames", pair(uncovered.columnInt(0), uncovered.columnInt(1)),
           "is missing: frames row " + std::to_string(uncovered.columnInt(1)) +
               " names that location"});
  Statement stray(
      db.handle(),
      "SELECT c.location_id, c.frame_id FROM location_frames c "
      "LEFT JOIN frames f ON f.id = c.frame_id WHERE f.location_id IS NOT c.location_id");
  while (stray.step())
    found({"location_frames", pair(stray.columnInt(0), stray.columnInt(1)),
           "is there, but frames row " + std::to_string(stray.columnInt(1)) +
               " names another location: it was added"});
  Statement hypotheses(
      db.handle(),
      "SELECT f.id, f.outcome = 2 FROM frames f WHERE (f.outcome = 2) = EXISTS (SELECT 1 FROM "
      "hypotheses h WHERE h.frame_id = f.id)");
  while (hypotheses.step())
    found({"hypotheses", std::to_string(hypotheses.columnInt(0)),
           hypotheses.columnInt(1) != 0
               ? "is there, for a bad frame (which has none): it was added"
               : "is missing: every frame but a bad one has its hypothesis"});
}

void fillLocationRows(Database& db) {
  std::vector<std::pair<std::int64_t, std::int64_t>> sums;
  {
    std::map<std::int64_t, std::map<std::string, std::string>> settings;
    std::map<std::int64_t, std::string> sources;
    Statement sessions(db.handle(), "SELECT id, source FROM sessions");
    while (sessions.step()) {
      settings[sessions.columnInt(0)];
      sources[sessions.columnInt(0)] = sessions.columnText(1);
    }
    Statement read(db.handle(), "SELECT session_id, key, value FROM settings");
    while (read.step()) settings[read.columnInt(0)][read.columnText(1)] = read.columnText(2);
    Statement write(db.handle(), "UPDATE sessions SET settings_digest = ?2 WHERE id = ?1");
    for (const auto& [id, values] : settings) {
      write.bind(1, id);
      write.bind(2, std::int64_t{settingsDigest(id, sources[id], values)});
      write.run();
    }
  }
  {
    Statement read(db.handle(), "SELECT location_id, wm_age FROM wm_entries");
    while (read.step())
      sums.emplace_back(read.columnInt(0), wmEntryChecksum(read.columnInt(0), read.columnInt(1)));
    Statement write(db.handle(), "UPDATE wm_entries SET checksum = ?2 WHERE location_id = ?1");
    for (const auto& [id, sum] : sums) {
      write.bind(1, id);
      write.bind(2, sum);
      write.run();
    }
  }
  sums.clear();
  {
    Statement read(db.handle(), "SELECT location_id, probability FROM filter_posterior");
    while (read.step())
      sums.emplace_back(read.columnInt(0),
                        posteriorChecksum(read.columnInt(0), read.columnDouble(1)));
    Statement write(db.handle(),
                    "UPDATE filter_posterior SET checksum = ?2 WHERE location_id = ?1");
    for (const auto& [id, sum] : sums) {
      write.bind(1, id);
      write.bind(2, sum);
      write.run();
    }
  }
  struct Location {
    std::int64_t id, held, digest;
  };
  std::vector<Location> locations;
  {
    Statement held(
        db.handle(),
        "SELECT l.id, "
        "(EXISTS (SELECT 1 FROM place_codes p WHERE p.location_id = l.id)) * 1 + "
        "(EXISTS (SELECT 1 FROM location_word_descriptors d WHERE d.location_id = l.id)) "
        "* 2 + (EXISTS (SELECT 1 FROM engine_state s WHERE s.key = '" +
            std::string(kLocationKeypointsKeyPrefix) +
            "' || l.id)) * 4 + "
            "(EXISTS (SELECT 1 FROM wm_entries w WHERE w.location_id = l.id)) * 8 "
            "FROM locations l ORDER BY l.id");
    Statement refs(db.handle(),
                   "SELECT word_id, x, y, size, angle, response FROM word_refs WHERE location_id = "
                   "?1 ORDER BY ordinal");
    while (held.step()) {
      const std::int64_t id = held.columnInt(0);
      RefsDigest digest(id);
      refs.reset();
      refs.bind(1, id);
      while (refs.step())
        digest.add(refs.columnInt(0), refs.columnDouble(1), refs.columnDouble(2),
                   refs.columnDouble(3), refs.columnDouble(4), refs.columnDouble(5));
      locations.push_back({id, held.columnInt(1), digest.value()});
    }
  }
  {
    std::vector<std::pair<std::int64_t, std::int64_t>> rows;
    Statement read(db.handle(), "SELECT id, session_id, weight, created_frame FROM locations");
    while (read.step())
      rows.emplace_back(read.columnInt(0),
                        locationChecksum(read.columnInt(0), read.columnInt(1), read.columnInt(2),
                                         read.columnOptionalInt(3)));
    Statement write(db.handle(), "UPDATE locations SET checksum = ?2 WHERE id = ?1");
    for (const auto& [id, sum] : rows) {
      write.bind(1, id);
      write.bind(2, sum);
      write.run();
    }
  }
  db.exec(
      "UPDATE locations SET link_count = (SELECT count(*) FROM links k WHERE k.location_a = "
      "locations.id) + (SELECT count(*) FROM links k WHERE k.location_b = locations.id)");
  Statement write(db.handle(), "UPDATE locations SET held = ?2, refs_digest = ?3 WHERE id = ?1");
  for (const Location& l : locations) {
    write.bind(1, l.id);
    write.bind(2, l.held);
    write.bind(3, l.digest);
    write.run();
  }
}

}  // namespace placedb::storage::detail
