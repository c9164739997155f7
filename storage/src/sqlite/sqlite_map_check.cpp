// placedb check: every page, key and checksum of a map, without writing.
#include "backends.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>

#include "placedb/storage/map_files.h"
#include "placedb/storage/map_store.h"
#include "placedb/storage/migrations.h"
#include "sqlite/database.h"
#include "sqlite/kd_node_journal.h"
#include "sqlite/map_file_check.h"
#include "sqlite/sqlite_checksums.h"
#include "sqlite/sqlite_location_rows.h"

namespace placedb::storage {
namespace {

// The first schema with fleet maps' tables (side sessions a copy may bring).
constexpr int kFleetSchemaVersion = 11;
constexpr int kLocationWordsSchemaVersion = 13;
constexpr int kKdNodeJournalSchemaVersion = 20;

using detail::Database;
using detail::Statement;

constexpr std::int64_t kProgressEvery = 20000;

// A kd-forest node row of kd_nodes or session_kd_nodes: tree, node, left and right child, split
// dimension and value from column `first` on, then its checksum.
bool kdNodeMatches(const Statement& s, int first) {
  return detail::checksumMatches(
      s, first + 6,
      detail::kdNodeChecksum(s.columnInt(first), s.columnInt(first + 1), s.columnInt(first + 2),
                             s.columnInt(first + 3), s.columnInt(first + 4),
                             s.columnDouble(first + 5)));
}

std::string kdNodeName(const Statement& s, int first) {
  return "tree " + std::to_string(s.columnInt(first)) + ", node " +
         std::to_string(s.columnInt(first + 1));
}

class Checker {
 public:
  Checker(Database& db, const CheckOptions& options, CheckReport& report)
      : db_(db), options_(options), report_(report) {}

  void find(std::string table, std::string row, std::string problem) {
    ++report_.findings_total;
    if (report_.findings.size() < options_.max_findings)
      report_.findings.push_back({std::move(table), std::move(row), std::move(problem)});
  }

  void progress(const std::string& stage, std::int64_t done, std::int64_t total) {
    if (options_.progress) options_.progress({stage, done, total});
  }

  void pages() {
    progress("pages", 0, 0);
    Statement check(db_.handle(),
                    "PRAGMA integrity_check(" +
                        std::to_string(std::max<std::size_t>(1, options_.max_findings)) + ")");
    while (check.step()) {
      const std::string line = check.columnText(0);
      if (line != "ok") find("sqlite", "", line);
    }
  }

  void foreignKeys() {
    progress("foreign keys", 0, 0);
    Statement check(db_.handle(), "PRAGMA foreign_key_check");
    while (check.step())
      find(check.columnText(0), check.isNull(1) ? "" : std::to_string(check.columnInt(1)),
           "refers to a missing row of " + check.columnText(2));
  }

  // Visits every row of `sql`; `verify` returns false for a damaged row and names it.
  template <typename Verify>
  void rows(const std::string& table, const std::string& sql, Verify verify) {
    // Counted for the progress line only: a count is a scan of its own.
    const std::int64_t total =
        options_.progress ? db_.queryInt("SELECT count(*) FROM " + table) : 0;
    progress(table, 0, total);
    Statement s(db_.handle(), sql);
    std::int64_t done = 0;
    while (s.step()) {
      verify(s);
      if (++done % kProgressEvery == 0) progress(table, done, total);
    }
    report_.rows_checked[table] = done;
    progress(table, done, total);
  }

  void checksums() {
    rows("words", "SELECT id, created_frame, descriptor_type, dim, descriptor, checksum FROM words",
         [&](const Statement& s) {
           const auto [data, size] = s.columnBlobView(4);
           const std::int64_t id = s.columnInt(0);
           if (!detail::checksumMatches(
                   s, 5,
                   detail::wordChecksum(id, s.columnOptionalInt(1), s.columnInt(2), s.columnInt(3),
                                        data, size)))
             return find("words", std::to_string(id), "fails its checksum");
           if (s.columnInt(2) == 0) {
             for (std::size_t at = 0; at + sizeof(float) <= size; at += sizeof(float)) {
               float value;
               std::memcpy(&value, data + at, sizeof value);
               if (!std::isfinite(value))
                 return find("words", std::to_string(id),
                             "holds a value that is not a finite number");
             }
           }
         });
    rows(
        "place_codes", "SELECT location_id, code, checksum FROM place_codes",
        [&](const Statement& s) {
          const auto [data, size] = s.columnBlobView(1);
          if (!detail::checksumMatches(s, 2, detail::placeCodeChecksum(s.columnInt(0), data, size)))
            find("place_codes", std::to_string(s.columnInt(0)), "fails its checksum");
        });
    std::string kd_rows_text;
    bool kd_rows_recorded = false;
    rows("engine_state", "SELECT key, value, checksum FROM engine_state", [&](const Statement& s) {
      const std::string key = s.columnText(0);
      const auto [data, size] = s.columnBlobView(1);
      if (!detail::checksumMatches(s, 2, detail::stateChecksum(key, data, size)))
        return find("engine_state", "'" + key + "'", "fails its checksum");
      if (key == detail::kKdNodeRowsKey) {
        kd_rows_recorded = true;
        kd_rows_text = s.columnText(1);
      }
    });
    std::int64_t kd_rows = 0;
    rows("kd_nodes",
         "SELECT tree, node, left_child, right_child, split_dim, split_value, checksum "
         "FROM kd_nodes",
         [&](const Statement& s) {
           ++kd_rows;
           if (!kdNodeMatches(s, 0))
             find("kd_nodes", "(" + kdNodeName(s, 0) + ")", "fails its checksum");
         });
    if (!kd_rows_recorded)
      find("engine_state", std::string("'") + detail::kKdNodeRowsKey + "'", "is missing");
    else if (kd_rows_text != std::to_string(kd_rows))
      find("kd_nodes", "",
           "holds " + std::to_string(kd_rows) + " rows where the map recorded " + kd_rows_text +
               " (rows were deleted or added)");
  }

  // The kd-forest's journalled changes (schema 20): each row's sum, and whole records.
  void kdNodeJournal() {
    rows("kd_node_journal", "SELECT seq, changes, checksum FROM kd_node_journal",
         [&](const Statement& s) {
           detail::KdNodeChanges changes;
           if (const char* problem = detail::kdNodeJournalRowProblem(s, &changes))
             find("kd_node_journal", std::to_string(s.columnInt(0)), problem);
         });
  }

  // The copies of each location's words (schema 13).
  void locationWordDescriptors() {
    rows("location_word_descriptors",
         "SELECT location_id, dim, words, checksum FROM location_word_descriptors",
         [&](const Statement& s) {
           const std::int64_t id = s.columnInt(0);
           const auto [data, size] = s.columnBlobView(2);
           if (!detail::checksumMatches(
                   s, 3, detail::locationWordDescriptorsChecksum(id, s.columnInt(1), data, size)))
             return find("location_word_descriptors", std::to_string(id), "fails its checksum");
           const std::string fault =
               detail::locationWordDescriptorsFault(id, s.columnInt(1), data, size);
           if (!fault.empty()) find("location_word_descriptors", std::to_string(id), fault);
         });
  }

  // Side sessions a copy of a fleet map brought (schema 11): their own engine state and
  // kd-forest, with each session's forest row count, as the main line's.
  void sideSessions() {
    std::map<std::int64_t, std::string> recorded;
    rows("session_state", "SELECT session_id, key, value, checksum FROM session_state",
         [&](const Statement& s) {
           const std::string key = s.columnText(1);
           const auto [data, size] = s.columnBlobView(2);
           if (!detail::checksumMatches(s, 3, detail::stateChecksum(key, data, size)))
             return find("session_state", std::to_string(s.columnInt(0)) + " '" + key + "'",
                         "fails its checksum");
           if (key == detail::kKdNodeRowsKey) recorded[s.columnInt(0)] = s.columnText(2);
         });
    std::map<std::int64_t, std::int64_t> counted;
    rows("session_kd_nodes",
         "SELECT session_id, tree, node, left_child, right_child, split_dim, split_value, "
         "checksum FROM session_kd_nodes",
         [&](const Statement& s) {
           ++counted[s.columnInt(0)];
           if (!kdNodeMatches(s, 1))
             find("session_kd_nodes",
                  "(session " + std::to_string(s.columnInt(0)) + ", " + kdNodeName(s, 1) + ")",
                  "fails its checksum");
         });
    for (const auto& [session, text] : recorded)
      if (text != std::to_string(counted[session]))
        find("session_kd_nodes", "session " + std::to_string(session),
             "holds " + std::to_string(counted[session]) + " rows where the map recorded " + text);
  }

  // What every location's rows must hold (schema 15): the rows its held bits name and no others,
  // its references against their digest, a valid tier; and the sums of the posterior's rows.
  void locationRows() {
    progress("locations", 0, 0);
    const auto sink = [this](CheckFinding f) {
      find(std::move(f.table), std::move(f.row), std::move(f.problem));
    };
    detail::checkSessionRows(db_, sink);
    detail::checkLocationRows(db_, sink);
    progress("word_refs", 0, 0);
    detail::checkLocationRefs(db_, sink);
    detail::checkLinkCounts(db_, sink);
    progress("frames", 0, 0);
    detail::checkFrameRows(db_, sink);
    rows("filter_posterior", "SELECT location_id, probability, checksum FROM filter_posterior",
         [&](const Statement& s) {
           if (!detail::checksumMatches(
                   s, 2, detail::posteriorChecksum(s.columnInt(0), s.columnDouble(1))))
             find("filter_posterior", std::to_string(s.columnInt(0)), "fails its checksum");
         });
  }

  // Values the engine refuses when it loads them, found here without loading the engine.
  void values() {
    progress("values", 0, 0);
    Statement weights(db_.handle(), "SELECT id FROM locations WHERE weight < 0");
    while (weights.step())
      find("locations", std::to_string(weights.columnInt(0)), "has a negative weight");
    Statement posterior(db_.handle(),
                        "SELECT location_id FROM filter_posterior "
                        "WHERE NOT (probability >= 0 AND probability <= 1)");
    while (posterior.step())
      find("filter_posterior", std::to_string(posterior.columnInt(0)),
           "holds a probability outside [0, 1]");
  }

 private:
  Database& db_;
  const CheckOptions& options_;
  CheckReport& report_;
};

// A connection that could write (SQLite verifies CHECK constraints only on such a one) but never
// does. A -wal file with frames in it stays as it is: closing would otherwise checkpoint it into
// the map file.
std::unique_ptr<Database> openCheckConnection(const std::string& path, bool* writable) {
  std::error_code error;
  const auto wal_size = std::filesystem::file_size(walFile(path), error);
  const bool wal_has_frames = !error && wal_size > 0;
  try {
    auto db = std::make_unique<Database>(path, SQLITE_OPEN_READWRITE);
    db->setLabel(path);
    if (wal_has_frames)
      sqlite3_db_config(db->handle(), SQLITE_DBCONFIG_NO_CKPT_ON_CLOSE, 1, nullptr);
    if (sqlite3_db_readonly(db->handle(), "main") != 1) {
      sqlite3_busy_timeout(db->handle(), 5000);
      db->queryInt("SELECT count(*) FROM sqlite_master");
      *writable = true;
      return db;
    }
  } catch (const StorageError& e) {
    const int primary = e.sqliteCode() & 0xff;
    if (primary != SQLITE_READONLY && primary != SQLITE_CANTOPEN && primary != SQLITE_PERM) throw;
  }
  *writable = false;
  return detail::openForInspection(path);
}

}  // namespace

namespace detail {

void checkRowSums(Database& db, const std::string& path) {
  CheckOptions options;
  options.max_findings = 1;
  CheckReport report;
  Checker checker(db, options, report);
  checker.checksums();
  checker.sideSessions();
  checker.locationWordDescriptors();
  if (!report.findings.empty()) {
    const CheckFinding& f = report.findings.front();
    refuseDamagedRow(path, f.table, f.row, f.problem);
  }
}

}  // namespace detail

CheckReport checkSqliteMap(const std::string& given_path, const CheckOptions& options) {
  const std::string path = detail::resolveMapPath(given_path);
  const detail::FileState state = detail::checkRawFile(path);
  if (state == detail::FileState::kMissing)
    throw StorageError(ErrorCode::kIo, "map " + path + " not found");
  if (state == detail::FileState::kEmpty)
    throw StorageError(ErrorCode::kMapRefused, "map " + path + " refused: empty file");
  const auto identity = detail::inspectIdentity(path);
  const auto verdict = detail::judgeIdentity(identity, path, currentSchemaVersion());
  if (verdict == detail::Verdict::kBlankSqlite)
    throw StorageError(ErrorCode::kMapRefused,
                       "map " + path + " refused: an empty SQLite database, not a placedb map");

  CheckReport report;
  report.schema_version = identity.user_version;
  report.checksums = identity.user_version >= detail::kChecksumSchemaVersion;
  bool writable = false;
  auto db = openCheckConnection(path, &writable);
  report.constraints_checked = writable;
  Checker checker(*db, options, report);
  // One read transaction: every stage sees the same committed frame while a writer maps on.
  db->exec("BEGIN");
  try {
    checker.pages();
    if (!report.ok()) {  // rows of a malformed file cannot be trusted to be read
      db->exec("COMMIT");
      return report;
    }
    // Tables of another schema than the version says: `map` refuses them (an upgrade would fail
    // halfway), and the row checks below would read columns that are not there.
    for (const auto& mismatch : detail::schemaMismatches(*db, report.schema_version))
      checker.find(
          "schema", "",
          mismatch + " (the map says schema " + std::to_string(report.schema_version) + ")");
    if (!report.ok()) {
      db->exec("COMMIT");
      return report;
    }
    checker.foreignKeys();
    if (report.checksums) checker.checksums();
    if (report.schema_version >= kFleetSchemaVersion) checker.sideSessions();
    if (report.schema_version >= kLocationWordsSchemaVersion) checker.locationWordDescriptors();
    if (report.schema_version >= kKdNodeJournalSchemaVersion) checker.kdNodeJournal();
    if (report.schema_version >= detail::kLocationRowsSchemaVersion) checker.locationRows();
    checker.values();
    if (report.ok() && options.last_check && report.schema_version == currentSchemaVersion()) {
      if (options.progress) options.progress({"engine state", 0, 0});
      const std::string problem = options.last_check();
      if (!problem.empty()) checker.find("engine", "", problem);
    }
  } catch (const StorageError& e) {
    sqlite3_exec(db->handle(), "ROLLBACK", nullptr, nullptr, nullptr);
    if (e.code() != ErrorCode::kMapRefused) throw;
    checker.find("sqlite", "", e.sqliteMessage().empty() ? e.what() : e.sqliteMessage());
    return report;
  }
  db->exec("COMMIT");
  return report;
}

}  // namespace placedb::storage
