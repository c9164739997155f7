// placedb check on a map on a PostgreSQL server: every row checksum, the kd_nodes row count and
// the values the engine refuses, in one read-only snapshot. Pages and keys are the server's
// own business (its constraints are always enforced; page damage is found by data checksums,
// initdb --data-checksums, or pg_amcheck), so there is no "pages" or "foreign keys" stage; but
// a reference's word and location, which no key guards since schema 16, are checked here.
#include <cmath>
#include <cstring>
#include <functional>
#include <map>

#include "backends.h"
#include "placedb/storage/map_check.h"
#include "placedb/storage/migrations.h"
#include "postgres/pg_connection.h"
#include "postgres/pg_map_store.h"
#include "row_checksums.h"

namespace placedb::storage {
namespace {

bool sumMatches(const detail::PgResult& r, int row, int column, std::uint32_t computed) {
  return !r.isNull(row, column) && r.integer(row, column) == std::int64_t{computed};
}

// A kd-forest node row of kd_nodes or session_kd_nodes: tree, node, left and right child, split
// dimension and value from column `first` on, then its checksum (as sqlite_map_check.cpp's).
bool kdNodeMatches(const detail::PgResult& r, int row, int first) {
  return sumMatches(r, row, first + 6,
                    detail::kdNodeChecksum(r.integer(row, first), r.integer(row, first + 1),
                                           r.integer(row, first + 2), r.integer(row, first + 3),
                                           r.integer(row, first + 4), r.real(row, first + 5)));
}

std::string kdNodeName(const detail::PgResult& r, int row, int first) {
  return "tree " + std::to_string(r.integer(row, first)) + ", node " +
         std::to_string(r.integer(row, first + 1));
}

class PgChecker {
 public:
  PgChecker(detail::PgConnection& db, const CheckOptions& options, CheckReport& report)
      : db_(db), options_(options), report_(report) {}

  void find(std::string table, std::string row, std::string problem) {
    ++report_.findings_total;
    if (report_.findings.size() < options_.max_findings)
      report_.findings.push_back({std::move(table), std::move(row), std::move(problem)});
  }

  // Reads a whole table at once: a check is rare and the rows of one table fit in memory.
  template <typename Verify>
  void rows(const std::string& table, const char* sql, Verify verify) {
    if (options_.progress) options_.progress({table, 0, 0});
    const auto r = db_.run(sql);
    for (int i = 0; i < r.rows(); ++i) verify(r, i);
    report_.rows_checked[table] = r.rows();
    if (options_.progress) options_.progress({table, r.rows(), r.rows()});
  }

  void checksums() {
    rows("words", "SELECT id, created_frame, descriptor_type, dim, descriptor, checksum FROM words",
         [&](const detail::PgResult& r, int i) {
           const auto [data, size] = r.bytes(i, 4);
           const std::int64_t id = r.integer(i, 0);
           if (!sumMatches(r, i, 5,
                           detail::wordChecksum(id, r.optionalInteger(i, 1), r.integer(i, 2),
                                                r.integer(i, 3), data, size)))
             return find("words", std::to_string(id), "fails its checksum");
           if (r.integer(i, 2) != 0) return;
           for (std::size_t at = 0; at + sizeof(float) <= size; at += sizeof(float)) {
             float value;
             std::memcpy(&value, data + at, sizeof value);
             if (!std::isfinite(value))
               return find("words", std::to_string(id),
                           "holds a value that is not a finite number");
           }
         });
    rows("place_codes", "SELECT location_id, code, checksum FROM place_codes",
         [&](const detail::PgResult& r, int i) {
           const auto [data, size] = r.bytes(i, 1);
           if (!sumMatches(r, i, 2, detail::placeCodeChecksum(r.integer(i, 0), data, size)))
             find("place_codes", std::to_string(r.integer(i, 0)), "fails its checksum");
         });
    rows(
        "location_word_descriptors",
        "SELECT location_id, dim, words, checksum FROM location_word_descriptors",
        [&](const detail::PgResult& r, int i) {
          const std::int64_t id = r.integer(i, 0);
          const auto [data, size] = r.bytes(i, 2);
          if (!sumMatches(r, i, 3,
                          detail::locationWordDescriptorsChecksum(id, r.integer(i, 1), data, size)))
            return find("location_word_descriptors", std::to_string(id), "fails its checksum");
          const std::string fault =
              detail::locationWordDescriptorsFault(id, r.integer(i, 1), data, size);
          if (!fault.empty()) find("location_word_descriptors", std::to_string(id), fault);
        });
    std::string kd_rows_text;
    bool kd_rows_recorded = false;
    rows("engine_state", "SELECT key, value, checksum FROM engine_state",
         [&](const detail::PgResult& r, int i) {
           const std::string key = r.text(i, 0);
           const auto [data, size] = r.bytes(i, 1);
           if (!sumMatches(r, i, 2, detail::stateChecksum(key, data, size)))
             return find("engine_state", "'" + key + "'", "fails its checksum");
           if (key == detail::kKdNodeRowsKey) {
             kd_rows_recorded = true;
             kd_rows_text.assign(reinterpret_cast<const char*>(data), size);
           }
         });
    std::int64_t kd_rows = 0;
    rows("kd_nodes",
         "SELECT tree, node, left_child, right_child, split_dim, split_value, checksum "
         "FROM kd_nodes",
         [&](const detail::PgResult& r, int i) {
           ++kd_rows;
           if (!kdNodeMatches(r, i, 0))
             find("kd_nodes", "(" + kdNodeName(r, i, 0) + ")", "fails its checksum");
         });
    if (!kd_rows_recorded)
      find("engine_state", std::string("'") + detail::kKdNodeRowsKey + "'", "is missing");
    else if (kd_rows_text != std::to_string(kd_rows))
      find("kd_nodes", "",
           "holds " + std::to_string(kd_rows) + " rows where the map recorded " + kd_rows_text +
               " (rows were deleted or added)");
  }

  // Side sessions of a fleet map (schema 11): their own engine state and kd-forest, with each
  // session's forest row count, as the main line's.
  void sideSessions() {
    std::map<std::int64_t, std::string> recorded;
    rows("session_state", "SELECT session_id, key, value, checksum FROM session_state",
         [&](const detail::PgResult& r, int i) {
           const std::string key = r.text(i, 1);
           const auto [data, size] = r.bytes(i, 2);
           const std::string row = std::to_string(r.integer(i, 0)) + " '" + key + "'";
           if (!sumMatches(r, i, 3, detail::stateChecksum(key, data, size)))
             return find("session_state", row, "fails its checksum");
           if (key == detail::kKdNodeRowsKey)
             recorded[r.integer(i, 0)].assign(reinterpret_cast<const char*>(data), size);
         });
    std::map<std::int64_t, std::int64_t> counted;
    rows("session_kd_nodes",
         "SELECT session_id, tree, node, left_child, right_child, split_dim, split_value, "
         "checksum FROM session_kd_nodes",
         [&](const detail::PgResult& r, int i) {
           ++counted[r.integer(i, 0)];
           if (!kdNodeMatches(r, i, 1))
             find("session_kd_nodes",
                  "(session " + std::to_string(r.integer(i, 0)) + ", " + kdNodeName(r, i, 1) + ")",
                  "fails its checksum");
         });
    for (const auto& [session, text] : recorded)
      if (text != std::to_string(counted[session]))
        find("session_kd_nodes", "session " + std::to_string(session),
             "holds " + std::to_string(counted[session]) + " rows where the map recorded " + text);
    // Their keys on sessions went in schema 23 (migrations/pg/0023).
    const auto orphans = db_.run(
        "SELECT t, session_id, count(*) FROM (SELECT 'session_state' AS t, session_id FROM "
        "session_state UNION ALL SELECT 'session_kd_nodes', session_id FROM session_kd_nodes "
        "UNION ALL SELECT 'session_memory', session_id FROM session_memory) r WHERE NOT EXISTS "
        "(SELECT 1 FROM sessions s WHERE s.id = r.session_id) GROUP BY 1, 2 ORDER BY 1, 2");
    for (int i = 0; i < orphans.rows(); ++i)
      find(orphans.text(i, 0), "session " + std::to_string(orphans.integer(i, 1)),
           std::to_string(orphans.integer(i, 2)) + " rows name session " +
               std::to_string(orphans.integer(i, 1)) + ", which is missing");
    const auto posterior = db_.run(
        "SELECT session_id, location_id FROM session_posterior WHERE NOT (probability >= 0 AND "
        "probability <= 1)");
    for (int i = 0; i < posterior.rows(); ++i)
      find("session_posterior",
           std::to_string(posterior.integer(i, 0)) + " " + std::to_string(posterior.integer(i, 1)),
           "holds a probability outside [0, 1]");
  }

  // Guards keyed to a role other than the map's owner (migrations/pg/0021): members of that role
  // write unchecked until the owner opens the map for writing, which keys them again.
  void guardKeys() {
    const auto stale = db_.run(
        "SELECT g.rel::text, g.name, pg_get_userbyid(c.relowner) FROM placedb_unkeyed_guards() g, "
        "pg_class c WHERE c.oid = 'placedb_meta'::regclass");
    for (int i = 0; i < stale.rows(); ++i)
      find("triggers", stale.text(i, 1) + " on " + stale.text(i, 0),
           "is keyed to another role than the map's owner " + stale.text(i, 2) +
               ": open the map for writing as " + stale.text(i, 2) + " to key it again");
  }

  void values() {
    if (options_.progress) options_.progress({"values", 0, 0});
    const auto weights = db_.run("SELECT id FROM locations WHERE weight < 0");
    for (int i = 0; i < weights.rows(); ++i)
      find("locations", std::to_string(weights.integer(i, 0)), "has a negative weight");
    const auto posterior = db_.run(
        "SELECT location_id FROM filter_posterior WHERE NOT (probability >= 0 AND probability "
        "<= 1)");
    for (int i = 0; i < posterior.rows(); ++i)
      find("filter_posterior", std::to_string(posterior.integer(i, 0)),
           "holds a probability outside [0, 1]");
    // word_refs has no foreign keys since schema 16 (migrations/pg/0016 says why): a reference
    // whose word or location was deleted by hand is found here, as the file's key check does.
    const auto dangling = db_.run(
        "SELECT r.location_id, r.ordinal, r.word_id, w.id IS NULL, l.id IS NULL FROM word_refs r "
        "LEFT JOIN words w ON w.id = r.word_id LEFT JOIN locations l ON l.id = r.location_id "
        "WHERE w.id IS NULL OR l.id IS NULL ORDER BY 1, 2");
    for (int i = 0; i < dangling.rows(); ++i)
      find("word_refs",
           std::to_string(dangling.integer(i, 0)) + " " + std::to_string(dangling.integer(i, 1)),
           dangling.boolean(i, 3)
               ? "names word " + std::to_string(dangling.integer(i, 2)) + ", which is missing"
               : "names location " + std::to_string(dangling.integer(i, 0)) + ", which is missing");
    // Nor has words.created_frame since schema 19 (migrations/pg/0019).
    const auto orphans = db_.run(
        "SELECT w.id, w.created_frame FROM words w WHERE w.created_frame IS NOT NULL AND NOT "
        "EXISTS (SELECT 1 FROM frames f WHERE f.id = w.created_frame) ORDER BY 1");
    for (int i = 0; i < orphans.rows(); ++i)
      find("words", std::to_string(orphans.integer(i, 0)),
           "names created frame " + std::to_string(orphans.integer(i, 1)) + ", which is missing");
  }

 private:
  detail::PgConnection& db_;
  const CheckOptions& options_;
  CheckReport& report_;
};

}  // namespace

CheckReport checkPgMap(const std::string& uri, const CheckOptions& options) {
  // The store's read-only open judges the map (no map: kIo; another schema: kMapRefused).
  PgMapStore store(uri, OpenMode::kReadOnly);
  detail::PgConnection db(uri, store.path(), OpenOptions().connect_timeout_s);
  CheckReport report;
  report.schema_version = store.schemaVersion();
  report.checksums = true;
  report.constraints_checked = true;  // the server enforces every constraint on write
  PgChecker checker(db, options, report);
  db.beginRead();
  try {
    checker.checksums();
    checker.sideSessions();
    checker.guardKeys();
    checker.values();
    // What every location and session must hold (schema 15), and every location's references
    // against their digest: the store's own checks, the first damaged row of each.
    for (const auto& stage : std::vector<std::function<void()>>{
             [&store] { store.checkStoredRows(); },
             [&store, &db] {
               const auto ids = db.run("SELECT id FROM locations ORDER BY id");
               std::vector<std::int64_t> chunk;
               for (int i = 0; i < ids.rows(); ++i) {
                 chunk.push_back(ids.integer(i, 0));
                 if (chunk.size() == 1024 || i + 1 == ids.rows()) {
                   store.loadWordRefs(chunk);
                   chunk.clear();
                 }
               }
             }}) {
      try {
        stage();
      } catch (const StorageError& e) {
        if (e.code() != ErrorCode::kMapRefused) throw;
        checker.find("structure", "", e.what());
      }
    }
    if (report.ok() && options.last_check) {
      if (options.progress) options.progress({"engine state", 0, 0});
      const std::string problem = options.last_check();
      if (!problem.empty()) checker.find("engine", "", problem);
    }
  } catch (...) {
    db.endReadQuietly();
    throw;
  }
  db.endReadQuietly();
  return report;
}

}  // namespace placedb::storage
