// `placedb check`, and damage inside rows (schema 8's checksums): a sound map passes and stays as
// it was; a damaged one is reported row by row with exit 4, and `placedb map` refuses it before
// any write. A randomised run damages random bytes of random rows; PLACEDB_DAMAGE_SECONDS makes it
// run for that long (fuzz/README.md gives the figures of a 10-minute run).
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>

#include "cli_map_edits.h"
#include "cli_scratch.h"

namespace placedb::testing {
namespace {

std::vector<std::string> companions(const fs::path& map) {
  std::vector<std::string> found;
  for (const char* suffix : {"-wal", "-shm", "-journal"})
    if (fs::exists(map.string() + suffix)) found.push_back(suffix);
  return found;
}

TEST(CliCheck, SoundMapPassesAndIsLeftAsFound) {
  auto seq = smallSequence(10);
  auto dir = scratchDir("CliCheck_sound");
  auto map = mappedCopy(seq, dir, "m.placedb");
  const std::string before = bytesOf(map);
  const auto companions_before = companions(map);
  auto r = placedb({"check", map.string(), "--json"}, dir);
  ASSERT_EQ(r.exit_code, 0) << describe(r);
  const auto report = nlohmann::json::parse(r.out);
  EXPECT_TRUE(report["ok"].get<bool>());
  EXPECT_TRUE(report["constraints_checked"].get<bool>());
  EXPECT_GT(report["rows_checked"]["words"].get<int>(), 100);
  EXPECT_GT(report["rows_checked"]["kd_nodes"].get<int>(), 10);
  EXPECT_TRUE(bytesOf(map) == before);
  EXPECT_EQ(companions(map), companions_before);
  auto text = placedb({"check", map.string()}, dir);
  EXPECT_EQ(text.exit_code, 0) << describe(text);
  EXPECT_NE(text.out.find("sound: no damage found"), std::string::npos) << text.out;
  EXPECT_NE(text.err.find("check: words"), std::string::npos) << "no progress: " << text.err;
}

TEST(CliCheck, ListsEveryDamagedRowAndExitsFour) {
  auto seq = smallSequence(10);
  auto dir = scratchDir("CliCheck_damaged");
  auto map = mappedCopy(seq, dir, "m.placedb");
  sqlExec(map,
          "UPDATE words SET descriptor = zeroblob(length(descriptor)) WHERE id IN (3, 40); "
          "PRAGMA ignore_check_constraints = 1; "
          "UPDATE locations SET tier = 7 WHERE id = (SELECT max(id) FROM locations)");
  const std::string before = bytesOf(map);
  auto r = placedb({"check", map.string(), "--json", "-q"}, dir);
  EXPECT_EQ(r.exit_code, 4) << describe(r);
  EXPECT_TRUE(r.err.empty() || r.err.find("check:") == std::string::npos) << r.err;
  EXPECT_NE(r.err.find("map " + map.string() + " damaged"), std::string::npos) << r.err;
  const auto report = nlohmann::json::parse(r.out);
  EXPECT_FALSE(report["ok"].get<bool>());
  // A CHECK violation is a page-level finding: rows are not read from such a file.
  ASSERT_FALSE(report["findings"].empty());
  EXPECT_EQ(report["findings"][0]["table"], "sqlite");
  EXPECT_TRUE(bytesOf(map) == before);

  sqlExec(map,
          "PRAGMA ignore_check_constraints = 1; "
          "UPDATE locations SET tier = 1 WHERE id = (SELECT max(id) FROM locations)");
  r = placedb({"check", map.string(), "--json", "-q"}, dir);
  EXPECT_EQ(r.exit_code, 4) << describe(r);
  const auto rows = nlohmann::json::parse(r.out)["findings"];
  ASSERT_EQ(rows.size(), 2u) << r.out;
  EXPECT_EQ(rows[0]["table"], "words");
  EXPECT_EQ(rows[0]["row"], "3");
  EXPECT_EQ(rows[1]["row"], "40");
  EXPECT_EQ(rows[0]["problem"], "fails its checksum");
}

TEST(CliCheck, MissingFileIsAnIoErrorAndOtherFilesAreRefused) {
  auto dir = scratchDir("CliCheck_refused");
  EXPECT_EQ(placedb({"check", (dir / "none.placedb").string()}, dir).exit_code, 3);
  const auto text = dir / "notes.txt";
  std::ofstream(text) << "not a map\n";
  auto r = placedb({"check", text.string()}, dir);
  EXPECT_EQ(r.exit_code, 4) << describe(r);
  EXPECT_NE(r.err.find(text.string()), std::string::npos) << r.err;
}

// ---- Random damage inside rows ----

struct Damage {
  std::string table;  // where the damage was made, as check names it
  std::string what;   // for failure messages
  bool read_at_open;  // `placedb map` reads the row when it resumes
};

class RowEditor {
 public:
  explicit RowEditor(const fs::path& map) { EXPECT_EQ(sqlite3_open(map.c_str(), &db_), SQLITE_OK); }
  ~RowEditor() { sqlite3_close(db_); }

  // Every row of `sql` (one key column, one value column) as key and bytes.
  std::vector<std::pair<std::string, std::string>> rows(const std::string& sql) {
    std::vector<std::pair<std::string, std::string>> out;
    sqlite3_stmt* s = nullptr;
    EXPECT_EQ(sqlite3_prepare_v2(db_, sql.c_str(), -1, &s, nullptr), SQLITE_OK) << sql;
    while (sqlite3_step(s) == SQLITE_ROW) {
      const auto* key = reinterpret_cast<const char*>(sqlite3_column_text(s, 0));
      const auto* value = static_cast<const char*>(sqlite3_column_blob(s, 1));
      out.emplace_back(key, std::string(value ? value : "", sqlite3_column_bytes(s, 1)));
    }
    sqlite3_finalize(s);
    return out;
  }
  // Runs `sql` with ?1 bound to `key` and ?2 to `value`, as a BLOB or as TEXT.
  void write(const std::string& sql, const std::string& key, const std::string& value,
             bool text = false) {
    sqlite3_stmt* s = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db_, sql.c_str(), -1, &s, nullptr), SQLITE_OK) << sql;
    sqlite3_bind_text(s, 1, key.c_str(), -1, SQLITE_TRANSIENT);
    if (text)
      sqlite3_bind_text(s, 2, value.data(), static_cast<int>(value.size()), SQLITE_TRANSIENT);
    else
      sqlite3_bind_blob(s, 2, value.data(), static_cast<int>(value.size()), SQLITE_TRANSIENT);
    EXPECT_EQ(sqlite3_step(s), SQLITE_DONE) << sql << ": " << sqlite3_errmsg(db_);
    sqlite3_finalize(s);
  }

 private:
  sqlite3* db_ = nullptr;
};

bool referenced(RowEditor& edit, const std::string& word_id) {
  return !edit.rows("SELECT word_id, '' FROM word_refs WHERE word_id = " + word_id + " LIMIT 1")
              .empty();
}

// One random change to one random row that leaves every page well-formed.
Damage damageOnce(const fs::path& map, std::mt19937_64& rng) {
  RowEditor edit(map);
  const auto pick = [&rng](std::size_t n) {
    return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng);
  };
  const auto flip = [&](std::string bytes) {
    bytes[pick(bytes.size())] ^= static_cast<char>(1u << pick(8));
    return bytes;
  };
  switch (pick(7)) {
    case 0: {  // one bit of a word's descriptor
      auto words = edit.rows("SELECT id, descriptor FROM words");
      const auto& [id, bytes] = words[pick(words.size())];
      edit.write("UPDATE words SET descriptor = ?2 WHERE id = CAST(?1 AS INTEGER)", id,
                 flip(bytes));
      // A word no location refers to any more is out of the kd-index and never read again.
      return {"words", "bit of word " + id, referenced(edit, id)};
    }
    case 1: {  // another word's descriptor and checksum
      auto words = edit.rows("SELECT id, descriptor FROM words");
      const auto& a = words[pick(words.size())];
      const auto& b = words[pick(words.size())];
      if (a.second == b.second) return damageOnce(map, rng);
      edit.write(
          "UPDATE words SET (descriptor, checksum) = (SELECT descriptor, checksum FROM words "
          "WHERE id = CAST(?2 AS INTEGER)) WHERE id = CAST(?1 AS INTEGER)",
          a.first, b.first, true);
      return {"words", "word " + a.first + " given word " + b.first + "'s descriptor",
              referenced(edit, a.first)};
    }
    case 2: {  // one bit of a place code
      auto codes = edit.rows("SELECT location_id, code FROM place_codes");
      const auto& [id, bytes] = codes[pick(codes.size())];
      edit.write("UPDATE place_codes SET code = ?2 WHERE location_id = CAST(?1 AS INTEGER)", id,
                 flip(bytes));
      return {"place_codes", "bit of place code " + id, true};
    }
    case 3: {  // one bit, or a cut, of an engine_state value
      auto state = edit.rows("SELECT key, value FROM engine_state");
      const auto& [key, bytes] = state[pick(state.size())];
      const bool cut = bytes.size() > 1 && pick(2) == 0;
      const std::string damaged = cut ? bytes.substr(0, pick(bytes.size())) : flip(bytes);
      const bool text =
          edit.rows("SELECT key, typeof(value) FROM engine_state WHERE key = '" + key + "'")[0]
              .second == "text";
      edit.write("UPDATE engine_state SET value = ?2 WHERE key = ?1", key, damaged, text);
      return {"engine_state", (cut ? "cut of '" : "bit of '") + key + "'",
              key.rfind("keypoint_descriptors/", 0) != 0 && key.rfind("latest_view/", 0) != 0};
    }
    case 4: {  // a kd-forest node's split value or child
      auto nodes = edit.rows("SELECT tree || ',' || node, split_value FROM kd_nodes");
      const auto& [id, value] = nodes[pick(nodes.size())];
      const auto comma = id.find(',');
      const std::string where =
          " WHERE tree = " + id.substr(0, comma) + " AND node = " + id.substr(comma + 1);
      const bool child = pick(2) == 0;
      edit.write(std::string("UPDATE kd_nodes SET ") +
                     (child ? "left_child = left_child + 2" : "split_value = split_value * 1.001") +
                     where + " AND ?1 = ?1 AND ?2 = ?2",
                 "", "");
      return {"kd_nodes", (child ? "child of node " : "split of node ") + id, true};
    }
    case 5: {  // one bit of the words kept beside a location
      auto rows = edit.rows("SELECT location_id, words FROM location_word_descriptors");
      const auto& [id, bytes] = rows[pick(rows.size())];
      edit.write(
          "UPDATE location_word_descriptors SET words = ?2 WHERE location_id = CAST(?1 AS INTEGER)",
          id, flip(bytes));
      // Read when the location comes back from long-term memory, not at open.
      return {"location_word_descriptors", "bit of location " + id + "'s words", false};
    }
    default: {  // a kd-forest node deleted
      auto nodes = edit.rows("SELECT tree || ',' || node, '' FROM kd_nodes");
      const auto& id = nodes[pick(nodes.size())].first;
      const auto comma = id.find(',');
      edit.write("DELETE FROM kd_nodes WHERE tree = " + id.substr(0, comma) +
                     " AND node = " + id.substr(comma + 1) + " AND ?1 = ?1 AND ?2 = ?2",
                 "", "");
      return {"kd_nodes", "node " + id + " deleted", true};
    }
  }
}

TEST(CliCheck, RandomDamageInsideRowsIsRefusedBeforeAnyWrite) {
  auto seq = smallSequence(12);
  auto dir = scratchDir("CliCheck_random");
  auto good = mappedCopy(seq, dir, "good.placedb", {"--stop-after", "8"});
  const char* seconds_env = std::getenv("PLACEDB_DAMAGE_SECONDS");
  const double seconds = seconds_env ? std::atof(seconds_env) : 0;
  const std::uint64_t seed = std::random_device{}();
  std::mt19937_64 rng(seed);
  std::map<std::string, int> made, map_refused;
  int runs = 0;
  const auto start = std::chrono::steady_clock::now();
  auto map = dir / "damaged.placedb";
  while (runs < 12 ||
         std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() <
             seconds) {
    ++runs;
    fs::copy_file(good, map, fs::copy_options::overwrite_existing);
    const Damage damage = damageOnce(map, rng);
    ++made[damage.table];
    const std::string context =
        "seed " + std::to_string(seed) + ", run " + std::to_string(runs) + ": " + damage.what;
    ASSERT_EQ(integrityCheck(map), "ok") << context;
    const std::string before = bytesOf(map);

    auto check = placedb({"check", map.string(), "--json", "-q"}, dir);
    ASSERT_EQ(check.exit_code, 4) << context << "\n" << describe(check);
    const auto report = nlohmann::json::parse(check.out);
    ASSERT_FALSE(report["findings"].empty()) << context;
    EXPECT_EQ(report["findings"][0]["table"], damage.table) << context << "\n" << check.out;
    ASSERT_TRUE(bytesOf(map) == before) << context;

    auto resume = placedb({"map", map.string(), (seq / "frames.txt").string(), "-q"}, dir);
    if (damage.read_at_open) {
      ASSERT_EQ(resume.exit_code, 4) << context << "\n" << describe(resume);
      ASSERT_NE(resume.err.find(map.string()), std::string::npos) << context;
      ASSERT_TRUE(bytesOf(map) == before) << context;
    } else {
      // A location's keypoints are read when it is next checked geometrically: the frame that
      // meets the damage is refused; the frames before it were sound and are kept.
      ASSERT_TRUE(resume.exit_code == 0 || resume.exit_code == 4) << context << describe(resume);
    }
    if (resume.exit_code == 4) ++map_refused[damage.table];
  }
  std::string summary;
  for (const auto& [table, n] : made)
    summary += " " + table + " " + std::to_string(map_refused[table]) + "/" + std::to_string(n);
  std::printf("random row damage: %d runs (seed %llu), check refused all; map refused:%s\n", runs,
              static_cast<unsigned long long>(seed), summary.c_str());
}

}  // namespace
}  // namespace placedb::testing
