// Damage made with plain SQL, as a careless user or a hostile one would: rows deleted, added and
// changed in every table the engine reads, counters behind and ahead of the rows (their
// checksums forged, as a tool that knows the sums could). Each variant is either found by
// `placedb check` and refused (kMapRefused, naming its table) by a mapping open and by a query
// open before anything is written, or harmless: `check` finds nothing and a resume decides
// exactly as one on the intact map. No variant may pass `check` and change a decision, and none
// that `check` reports may be written on.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <boost/crc.hpp>
#include <nlohmann/json.hpp>

#include "crash_scenario.h"
#include "placedb/map.h"
#include "placedb/storage/map_check.h"
#include "reliability_support.h"

namespace placedb::testing {
namespace {

namespace fs = std::filesystem;

constexpr int kMapped = 90;  // frames in the base map: its first session stops there
constexpr int kResumed = 8;  // frames a harmless variant's resume maps, compared with intact's

void sql(const fs::path& map, const std::string& text) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(map.c_str(), &db), SQLITE_OK);
  char* error = nullptr;
  const int rc = sqlite3_exec(db, text.c_str(), nullptr, nullptr, &error);
  EXPECT_EQ(rc, SQLITE_OK) << text << ": " << (error ? error : "");
  sqlite3_free(error);
  sqlite3_close(db);
}

std::int64_t number(const fs::path& map, const std::string& text) {
  sqlite3* db = nullptr;
  sqlite3_open(map.c_str(), &db);
  sqlite3_stmt* s = nullptr;
  sqlite3_prepare_v2(db, text.c_str(), -1, &s, nullptr);
  const std::int64_t value = sqlite3_step(s) == SQLITE_ROW ? sqlite3_column_int64(s, 0) : -1;
  sqlite3_finalize(s);
  sqlite3_close(db);
  return value;
}

// The sum an engine_state row carries (schema/SCHEMA.md, "Row checksums"): what a tool forging
// one computes.
std::int64_t stateSum(const std::string& key, const std::string& value) {
  boost::crc_optimal<32, 0x1EDC6F41, 0xFFFFFFFF, 0xFFFFFFFF, true, true> crc;
  const std::uint64_t size = key.size();
  unsigned char bytes[8];
  for (int i = 0; i < 8; ++i) bytes[i] = static_cast<unsigned char>(size >> (8 * i));
  crc.process_bytes(bytes, 8);
  crc.process_bytes(key.data(), key.size());
  crc.process_bytes(value.data(), value.size());
  return crc.checksum();
}

// engine.counters with `field` moved by `by`, its sum forged.
void shiftCounter(const fs::path& map, const std::string& field, std::int64_t by) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(map.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* s = nullptr;
  sqlite3_prepare_v2(db, "SELECT value FROM engine_state WHERE key = 'engine.counters'", -1, &s,
                     nullptr);
  ASSERT_EQ(sqlite3_step(s), SQLITE_ROW);
  auto counters = nlohmann::json::parse(reinterpret_cast<const char*>(sqlite3_column_text(s, 0)));
  sqlite3_finalize(s);
  counters[field] = counters[field].get<std::int64_t>() + by;
  const std::string text = counters.dump();
  sqlite3_prepare_v2(db, "UPDATE engine_state SET value = ?1, checksum = ?2 WHERE key = ?3", -1, &s,
                     nullptr);
  sqlite3_bind_text(s, 1, text.c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_int64(s, 2, stateSum("engine.counters", text));
  sqlite3_bind_text(s, 3, "engine.counters", -1, SQLITE_STATIC);
  EXPECT_EQ(sqlite3_step(s), SQLITE_DONE);
  sqlite3_finalize(s);
  sqlite3_close(db);
}

enum class Expect { kRefused, kHarmless };

struct Variant {
  std::string name;
  Expect expect;
  std::string table;  // the table the refusal names
  // SQL with {WM} (a location in working memory), {LTM} (one in long-term memory), {STM} (the
  // newest, in short-term memory), {MID} (a frame in the middle), {LAST} (the last frame); or
  // a counter of engine.counters to move (`counter`, `by`).
  std::string sql;
  std::string counter;
  std::int64_t by = 0;
};

Variant bySql(std::string name, Expect expect, std::string table, std::string text) {
  return {std::move(name), expect, std::move(table), std::move(text), "", 0};
}

Variant byCounter(std::string name, const char* counter, std::int64_t by) {
  return {std::move(name), Expect::kRefused, "engine.counters", "", counter, by};
}

const std::vector<Variant>& variants() {
  using E = Expect;
  static const std::vector<Variant> all = {
      // The cases.
      bySql("place code deleted", E::kRefused, "place_codes",
            "DELETE FROM place_codes WHERE location_id = {WM}"),
      bySql("keypoints deleted", E::kRefused, "engine_state",
            "DELETE FROM engine_state WHERE key = 'keypoint_descriptors/{WM}'"),
      bySql("references deleted", E::kRefused, "word_refs",
            "DELETE FROM word_refs WHERE location_id = {WM}"),
      bySql("keypoint at 1e300", E::kRefused, "word_refs",
            "UPDATE word_refs SET x = 1e300 WHERE location_id = {WM} AND ordinal = 0"),
      bySql("posterior deleted", E::kRefused, "filter_posterior", "DELETE FROM filter_posterior"),
      bySql("WM entry deleted", E::kRefused, "wm_entries",
            "DELETE FROM wm_entries WHERE location_id = {WM}"),
      bySql("every location to LTM", E::kRefused, "locations", "UPDATE locations SET tier = 2"),
      bySql("tier 7", E::kRefused, "locations",
            "PRAGMA ignore_check_constraints = 1; UPDATE locations SET tier = 7 WHERE id = {WM}"),
      bySql("location row deleted (keys off)", E::kRefused, "locations",
            "DELETE FROM locations WHERE id = {LTM}"),
      bySql("frame row deleted (keys off)", E::kRefused, "frames",
            "DELETE FROM frames WHERE id = {MID}"),
      byCounter("next_frame_id behind", "next_frame_id", -20),
      // Rows of long-term memory, read only when brought back.
      bySql("LTM place code deleted", E::kRefused, "place_codes",
            "DELETE FROM place_codes WHERE location_id = {LTM}"),
      bySql("LTM keypoints deleted", E::kRefused, "engine_state",
            "DELETE FROM engine_state WHERE key = 'keypoint_descriptors/{LTM}'"),
      bySql("LTM references deleted", E::kRefused, "word_refs",
            "DELETE FROM word_refs WHERE location_id = {LTM}"),
      bySql("LTM keypoint moved a pixel", E::kRefused, "word_refs",
            "UPDATE word_refs SET x = x + 1 WHERE location_id = {LTM} AND ordinal = 0"),
      bySql("LTM word descriptors deleted", E::kRefused, "location_word_descriptors",
            "DELETE FROM location_word_descriptors WHERE location_id = {LTM}"),
      // Added and changed rows.
      bySql("reference added", E::kRefused, "word_refs",
            "INSERT INTO word_refs SELECT location_id, 9999, word_id, x, y, size, angle, response "
            "FROM word_refs WHERE location_id = {WM} AND ordinal = 0"),
      bySql("one reference deleted", E::kRefused, "word_refs",
            "DELETE FROM word_refs WHERE location_id = {WM} AND ordinal = 1"),
      bySql("reference's word changed", E::kRefused, "word_refs",
            "UPDATE word_refs SET word_id = word_id + 1 WHERE location_id = {WM} AND ordinal = 0"),
      bySql("posterior row deleted", E::kRefused, "filter_posterior",
            "DELETE FROM filter_posterior WHERE location_id = {WM}"),
      bySql("posterior row changed", E::kRefused, "filter_posterior",
            "UPDATE filter_posterior SET probability = 0.5 WHERE location_id = {WM}"),
      bySql("posterior row added", E::kRefused, "filter_posterior",
            "INSERT INTO filter_posterior VALUES ({LTM}, 0.0, 0)"),
      bySql("WM age changed", E::kRefused, "wm_entries",
            "UPDATE wm_entries SET wm_age = wm_age + 1000 WHERE location_id = {WM}"),
      bySql("LTM WM entry deleted", E::kRefused, "wm_entries",
            "DELETE FROM wm_entries WHERE location_id = {LTM}"),
      bySql("one WM location to LTM", E::kRefused, "locations",
            "UPDATE locations SET tier = 2 WHERE id = {WM}"),
      bySql("WM and LTM swapped", E::kRefused, "locations",
            "UPDATE locations SET tier = CASE id WHEN {WM} THEN 2 ELSE 1 END WHERE id IN ({WM}, "
            "{LTM})"),
      bySql("STM and WM swapped", E::kRefused, "locations",
            "UPDATE locations SET tier = CASE id WHEN {WM} THEN 0 ELSE 1 END WHERE id IN ({WM}, "
            "{STM})"),
      bySql("weight changed", E::kRefused, "locations",
            "UPDATE locations SET weight = weight + 5 WHERE id = {WM}"),
      bySql("held bits cleared", E::kRefused, "locations",
            "UPDATE locations SET held = NULL WHERE id = {WM}"),
      bySql("link deleted", E::kRefused, "links",
            "DELETE FROM links WHERE location_a = (SELECT min(location_a) FROM links)"),
      bySql("link added", E::kRefused, "links",
            "INSERT INTO links VALUES ((SELECT min(id) FROM locations), {STM}, 1, 0.9)"),
      bySql("coverage deleted", E::kRefused, "location_frames",
            "DELETE FROM location_frames WHERE location_id = {LTM}"),
      bySql("coverage added", E::kRefused, "location_frames",
            "INSERT INTO location_frames VALUES ({LTM}, {LAST})"),
      bySql("hypothesis deleted", E::kRefused, "hypotheses",
            "DELETE FROM hypotheses WHERE frame_id = {MID}"),
      bySql("last frame deleted", E::kRefused, "frames", "DELETE FROM frames WHERE id = {LAST}"),
      bySql("setting deleted", E::kRefused, "settings",
            "DELETE FROM settings WHERE key = 'wm_max'"),
      bySql("setting changed", E::kRefused, "settings",
            "UPDATE settings SET value = '16' WHERE key = 'wm_max'"),
      bySql("setting added", E::kRefused, "settings", "INSERT INTO settings VALUES (1, 'zz', '1')"),
      bySql("session's source changed", E::kRefused, "settings",
            "UPDATE sessions SET source = 'elsewhere'"),
      bySql(
          "place code changed", E::kRefused, "place_codes",
          "UPDATE place_codes SET code = (SELECT code FROM place_codes WHERE location_id = {LTM}) "
          "WHERE location_id = {WM}"),
      bySql(
          "word deleted", E::kRefused, "words",
          "DELETE FROM words WHERE id = (SELECT word_id FROM word_refs WHERE location_id = {WM})"),
      bySql("newest word deleted", E::kRefused, "words",
            "DELETE FROM words WHERE id = (SELECT max(id) FROM words)"),
      bySql(
          "descriptor changed", E::kRefused, "words",
          "UPDATE words SET descriptor = (SELECT descriptor FROM words WHERE id = 1) WHERE id = 2"),
      bySql("kd-forest node deleted", E::kRefused, "kd_nodes",
            "DELETE FROM kd_nodes WHERE tree = 0 AND node = 0"),
      bySql("kd-forest node changed", E::kRefused, "kd_nodes",
            "UPDATE kd_nodes SET split_value = split_value + 1 WHERE tree = 0 AND node = 0"),
      bySql("counters deleted", E::kRefused, "engine.counters",
            "DELETE FROM engine_state WHERE key = 'engine.counters'"),
      bySql("vocabulary header deleted", E::kRefused, "vocabulary",
            "DELETE FROM engine_state WHERE key = 'vocabulary.header'"),
      bySql("place-code centres deleted", E::kRefused, "place_codes.centres",
            "DELETE FROM engine_state WHERE key = 'place_codes.centres'"),
      // Counters behind and ahead, with forged sums.
      byCounter("next_frame_id ahead", "next_frame_id", 5),
      byCounter("next_location_id behind", "next_location_id", -1),
      byCounter("next_location_id ahead", "next_location_id", 3),
      byCounter("next_wm_age behind", "next_wm_age", -1),
      byCounter("next_wm_age ahead", "next_wm_age", 7),
      // Rows that no decision reads.
      bySql("session marked interrupted", E::kHarmless, "", "UPDATE sessions SET clean_close = 0"),
      bySql("frame times changed", E::kHarmless, "", "UPDATE frames SET total_ms = 1e9"),
      bySql("link score changed", E::kHarmless, "",
            "UPDATE links SET score = 0.123 WHERE type = 1"),
  };
  return all;
}

std::string substituted(std::string text, const std::map<std::string, std::int64_t>& ids) {
  for (const auto& [name, id] : ids)
    for (std::size_t at; (at = text.find(name)) != std::string::npos;)
      text.replace(at, name.size(), std::to_string(id));
  return text;
}

// What the intact map's resume decides, frame by frame (hypotheses and outcomes).
std::vector<std::string> resumeDecisions(const fs::path& map) {
  auto m = Map::open(map.string(), crashMapOptions());
  m->resumeSession(m->lastSession()->id);
  synthetic::SyntheticSequence sequence(crashSequenceOptions(kMapped + kResumed));
  std::vector<std::string> out;
  for (int i = kMapped; i < kMapped + kResumed; ++i) {
    const FrameResult r = m->process(sequence.render(i), i, "f" + std::to_string(i));
    out.push_back(std::to_string(static_cast<int>(r.outcome)) + " " +
                  std::to_string(r.hypothesis.location_id) + " " +
                  std::to_string(r.hypothesis.score) + " " + (r.hypothesis.accepted ? "1" : "0"));
  }
  m->close();
  return out;
}

std::string refusalOf(const fs::path& map, Map::Mode mode) {
  try {
    Map::open(map.string(), crashMapOptions(), mode);
  } catch (const Error& e) {
    return std::to_string(static_cast<int>(e.code())) + " " + e.what();
  }
  return "";
}

TEST(DamageVariants, EachIsRefusedBeforeAnyWriteOrChangesNoDecision) {
  const fs::path dir = scratchDir("DamageVariants");
  const fs::path base = dir / "base.placedb";
  {
    auto m = Map::open(base.string(), crashMapOptions());
    m->beginSession("variants");
    synthetic::SyntheticSequence sequence(crashSequenceOptions(kMapped));
    for (int i = 0; i < kMapped; ++i) m->process(sequence.render(i), i, "f" + std::to_string(i));
    m->close();
  }
  const std::map<std::string, std::int64_t> ids = {
      {"{WM}", number(base,
                      "SELECT min(location_id) FROM filter_posterior p JOIN locations l "
                      "ON l.id = p.location_id WHERE l.tier = 1")},
      {"{LTM}", number(base, "SELECT min(id) FROM locations WHERE tier = 2")},
      {"{STM}", number(base, "SELECT max(id) FROM locations WHERE tier = 0")},
      {"{MID}", kMapped / 2},
      {"{LAST}", number(base, "SELECT max(id) FROM frames")}};
  for (const auto& [name, id] : ids) ASSERT_GT(id, 0) << name << ": the base map lacks a tier";
  ASSERT_TRUE(storage::checkMap(base.string()).ok());

  const fs::path intact = dir / "intact.placedb";
  fs::copy_file(base, intact);
  const std::vector<std::string> expected = resumeDecisions(intact);

  int refused = 0, harmless = 0;
  for (const Variant& v : variants()) {
    SCOPED_TRACE(v.name);
    const fs::path map = dir / "damaged.placedb";
    removeMapFiles(map);
    fs::copy_file(base, map);
    if (v.counter.empty())
      sql(map, substituted(v.sql, ids));
    else
      shiftCounter(map, v.counter, v.by);
    storage::CheckOptions options;
    options.last_check = [&map] {  // as `placedb check`: the engine's own load checks too
      const std::string why = refusalOf(map, Map::Mode::kLocalisation);
      return why.rfind("4 ", 0) == 0 ? why : std::string();
    };
    const storage::CheckReport report = storage::checkMap(map.string(), options);
    const std::string bytes = readBytes(map);
    const std::string mapping = refusalOf(map, Map::Mode::kMapping);
    const std::string query = refusalOf(map, Map::Mode::kLocalisation);
    if (v.expect == Expect::kRefused) {
      ++refused;
      EXPECT_FALSE(report.ok()) << "check found nothing";
      EXPECT_EQ(mapping.rfind("4 ", 0), 0u) << "mapping open: " << mapping;
      EXPECT_NE(mapping.find(v.table), std::string::npos) << mapping;
      EXPECT_EQ(query.rfind("4 ", 0), 0u) << "query open: " << query;
      EXPECT_TRUE(readBytes(map) == bytes) << "the refused map was written";
    } else {
      ++harmless;
      EXPECT_TRUE(report.ok()) << report.findings.front().table << " "
                               << report.findings.front().problem;
      EXPECT_EQ(mapping, "");
      EXPECT_EQ(query, "");
      if (mapping.empty()) {
        EXPECT_EQ(resumeDecisions(map), expected);
      }
    }
  }
  EXPECT_GE(refused + harmless, 40);
}

}  // namespace
}  // namespace placedb::testing
