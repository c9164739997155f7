// PgMapStore: what the engine keeps to resume exactly (engine state, kd-forest nodes, the
// filter's posterior), the memory tiers' place codes and ages, and vocabulary imports.
#include <cstring>
#include <map>

#include <nlohmann/json.hpp>

#include "location_rows.h"
#include "postgres/pg_map_store.h"
#include "row_checksums.h"

namespace placedb::storage {
namespace {

bool sumMatches(const detail::PgResult& r, int row, int column, std::uint32_t computed) {
  return !r.isNull(row, column) && r.integer(row, column) == std::int64_t{computed};
}

constexpr const char* kPutState =
    "INSERT INTO engine_state (key, value, checksum) VALUES ($1, $2, $3) "
    "ON CONFLICT (key) DO UPDATE SET value = excluded.value, checksum = excluded.checksum";

}  // namespace

// ---- Engine state ----

void PgMapStore::putState(const std::string& key, const std::vector<std::uint8_t>& value) {
  if (sideKey(key)) return sidePutState(key, value.data(), value.size());
  auto scope = writeScope();
  db_->send(kPutState,
            detail::PgParams()
                .add(key)
                .addBytes(value.data(), value.size())
                .add(std::int64_t{detail::stateChecksum(key, value.data(), value.size())}));
  if (const auto location = locationOfKeypointsKey(key))
    markHeld(*location, detail::kHeldKeypoints, true);
  scope.commit();
}

void PgMapStore::putState(const std::string& key, const std::string& value) {
  if (sideKey(key)) return sidePutState(key, value.data(), value.size());
  auto scope = writeScope();
  // Text is stored as its bytes: the column is bytea, as SQLite's is a BLOB-or-text.
  db_->send(kPutState,
            detail::PgParams()
                .add(key)
                .addBytes(value.data(), value.size())
                .add(std::int64_t{detail::stateChecksum(key, value.data(), value.size())}));
  scope.commit();
}

std::optional<std::vector<std::uint8_t>> PgMapStore::getState(const std::string& key) const {
  if (sideKey(key)) return sideGetState(key);
  const auto r = db_->run("SELECT value, checksum FROM engine_state WHERE key = $1",
                          detail::PgParams().add(key));
  if (r.rows() == 0) return std::nullopt;
  const auto [data, size] = r.bytes(0, 0);
  if (!sumMatches(r, 0, 1, detail::stateChecksum(key, data, size)))
    detail::refuseDamagedRow(label_, "engine_state", "'" + key + "'", "fails its checksum");
  return std::vector<std::uint8_t>(data, data + size);
}

std::optional<std::string> PgMapStore::getStateText(const std::string& key) const {
  auto bytes = getState(key);
  if (!bytes) return std::nullopt;
  return std::string(bytes->begin(), bytes->end());
}

void PgMapStore::deleteState(const std::string& key) {
  if (sideKey(key)) return sideDeleteState(key);
  auto scope = writeScope();
  db_->send("DELETE FROM engine_state WHERE key = $1", detail::PgParams().add(key));
  if (const auto location = locationOfKeypointsKey(key))
    markHeld(*location, detail::kHeldKeypoints, false);
  scope.commit();
}

std::int64_t PgMapStore::storedKdNodeRows() const {
  const auto text = getStateText(detail::kKdNodeRowsKey);
  if (!text) detail::refuseDamagedRow(label_, "engine_state", detail::kKdNodeRowsKey, "is missing");
  try {
    std::size_t used = 0;
    const long long rows = std::stoll(*text, &used);
    if (used == text->size() && rows >= 0) return rows;
  } catch (const std::exception&) {
  }
  detail::refuseDamagedRow(label_, "engine_state", detail::kKdNodeRowsKey, "is not a row count");
}

void PgMapStore::writeKdNodes(const std::vector<KdNodeRecord>& upserts,
                              const std::vector<std::pair<int, std::int64_t>>& deletions,
                              bool replace_all) {
  // A side session keeps its nodes in session_kd_nodes, its id the first key and parameter; the
  // statements are otherwise the main line's.
  const bool side = side_session_ != 0;
  auto params = [&] {
    detail::PgParams p;
    if (side) p.add(side_session_);
    return p;
  };
  auto scope = writeScope();
  std::int64_t rows = 0;
  if (replace_all) {
    db_->run(side ? "DELETE FROM session_kd_nodes WHERE session_id = $1" : "DELETE FROM kd_nodes",
             params());
  } else {
    rows = storedKdNodeRows();
  }
  if (!deletions.empty()) {
    std::vector<std::int64_t> trees, nodes;
    for (const auto& [tree, node] : deletions) {
      trees.push_back(tree);
      nodes.push_back(node);
    }
    rows -= db_->run(side ? "DELETE FROM session_kd_nodes k USING unnest($2::int8[], $3::int8[]) "
                            "AS d(t, n) WHERE k.session_id = $1 AND k.tree = d.t AND k.node = d.n"
                          : "DELETE FROM kd_nodes k USING unnest($1::int8[], $2::int8[]) AS d(t, "
                            "n) WHERE k.tree = d.t AND k.node = d.n",
                     params().addArray(trees).addArray(nodes))
                .changed();
  }
  if (!upserts.empty()) {
    // One row per node, the last given winning (as the SQLite store's update-then-insert does):
    // one INSERT ... ON CONFLICT may not touch a row twice.
    std::map<std::pair<int, std::int64_t>, const KdNodeRecord*> last;
    for (const KdNodeRecord& n : upserts) last[{n.tree, n.node}] = &n;
    std::vector<std::int64_t> tree, node, left, right, dim, sum;
    std::vector<double> value;
    for (const auto& [key, n] : last) {
      tree.push_back(n->tree);
      node.push_back(n->node);
      left.push_back(n->left_child);
      right.push_back(n->right_child);
      dim.push_back(n->split_dim);
      value.push_back(n->split_value);
      sum.push_back(detail::kdNodeChecksum(n->tree, n->node, n->left_child, n->right_child,
                                           n->split_dim, n->split_value));
    }
    // xmax is 0 on a row this statement inserted: the row count follows without a count(*).
    const auto r = db_->run(
        side ? "INSERT INTO session_kd_nodes (session_id, tree, node, left_child, right_child, "
               "split_dim, split_value, checksum) SELECT $1, * FROM unnest($2::int8[], "
               "$3::int8[], $4::int8[], $5::int8[], $6::int8[], $7::float8[], $8::int8[]) ON "
               "CONFLICT (session_id, tree, node) DO UPDATE SET left_child = excluded.left_child, "
               "right_child = excluded.right_child, split_dim = excluded.split_dim, split_value = "
               "excluded.split_value, checksum = excluded.checksum RETURNING (xmax = 0)"
             : "INSERT INTO kd_nodes (tree, node, left_child, right_child, split_dim, split_value, "
               "checksum) SELECT * FROM unnest($1::int8[], $2::int8[], $3::int8[], $4::int8[], "
               "$5::int8[], $6::float8[], $7::int8[]) ON CONFLICT (tree, node) DO UPDATE SET "
               "left_child = excluded.left_child, right_child = excluded.right_child, "
               "split_dim = excluded.split_dim, split_value = excluded.split_value, "
               "checksum = excluded.checksum RETURNING (xmax = 0)",
        params()
            .addArray(tree)
            .addArray(node)
            .addArray(left)
            .addArray(right)
            .addArray(dim)
            .addArray(value)
            .addArray(sum));
    for (int i = 0; i < r.rows(); ++i) rows += r.boolean(i, 0) ? 1 : 0;
  }
  putState(detail::kKdNodeRowsKey, std::to_string(rows));
  scope.commit();
}

std::vector<KdNodeRecord> PgMapStore::loadKdNodes() const {
  if (side_session_) return sideLoadKdNodes();
  const auto r = db_->run(
      "SELECT tree, node, left_child, right_child, split_dim, split_value, checksum FROM kd_nodes "
      "ORDER BY tree, node");
  std::vector<KdNodeRecord> out;
  out.reserve(r.rows());
  for (int i = 0; i < r.rows(); ++i) {
    KdNodeRecord n;
    n.tree = static_cast<int>(r.integer(i, 0));
    n.node = r.integer(i, 1);
    n.left_child = r.integer(i, 2);
    n.right_child = r.integer(i, 3);
    n.split_dim = static_cast<int>(r.integer(i, 4));
    n.split_value = r.real(i, 5);
    if (!sumMatches(r, i, 6,
                    detail::kdNodeChecksum(r.integer(i, 0), n.node, n.left_child, n.right_child,
                                           r.integer(i, 4), n.split_value)))
      detail::refuseDamagedRow(
          label_, "kd_nodes",
          "(tree " + std::to_string(n.tree) + ", node " + std::to_string(n.node) + ")",
          "fails its checksum");
    out.push_back(n);
  }
  const std::int64_t stored = storedKdNodeRows();
  if (stored != static_cast<std::int64_t>(out.size()))
    throw StorageError(ErrorCode::kMapRefused,
                       "map " + label_ + " damaged: kd_nodes holds " + std::to_string(out.size()) +
                           " rows where the map recorded " + std::to_string(stored) +
                           " (rows were deleted or added); nothing was written");
  return out;
}

void PgMapStore::putPosterior(const std::vector<std::pair<std::int64_t, double>>& posterior) {
  std::vector<std::int64_t> ids, sums;
  std::vector<double> probabilities;
  for (const auto& [id, p] : posterior) {
    ids.push_back(id);
    probabilities.push_back(p);
    sums.push_back(detail::posteriorChecksum(id, p));
  }
  if (side_session_) return sidePutPosterior(ids, probabilities);
  auto scope = writeScope();
  // One row of arrays (schema 18, migrations/pg/0018 says why): the normalisation changes every
  // entry every frame, so rows per entry were all rewritten each frame.
  db_->send(
      "INSERT INTO filter_posterior_vector (one_row, location_ids, probabilities, checksums) "
      "VALUES (true, $1, $2, $3) ON CONFLICT (one_row) DO UPDATE SET location_ids = "
      "excluded.location_ids, probabilities = excluded.probabilities, checksums = "
      "excluded.checksums",
      detail::PgParams().addArray(ids).addArray(probabilities).addArray(sums));
  scope.commit();
}

std::vector<std::pair<std::int64_t, double>> PgMapStore::loadPosterior() const {
  if (side_session_) return sideLoadPosterior();
  const auto r = db_->run(
      "SELECT location_id, probability, checksum FROM filter_posterior ORDER BY location_id");
  std::vector<std::pair<std::int64_t, double>> out;
  for (int i = 0; i < r.rows(); ++i) {
    const std::int64_t id = r.integer(i, 0);
    if (!sumMatches(r, i, 2, detail::posteriorChecksum(id, r.real(i, 1))))
      detail::refuseDamagedRow(label_, "filter_posterior", std::to_string(id),
                               "fails its checksum");
    out.emplace_back(id, r.real(i, 1));
  }
  return out;
}

// ---- Memory tiers ----

void PgMapStore::putPlaceCode(std::int64_t location_id, const std::vector<std::int8_t>& code) {
  auto scope = writeScope();
  db_->send(
      "INSERT INTO place_codes (location_id, code, checksum) VALUES ($1, $2, $3) "
      "ON CONFLICT (location_id) DO UPDATE SET code = excluded.code, checksum = excluded.checksum",
      detail::PgParams()
          .add(location_id)
          .addBytes(code.data(), code.size())
          .add(std::int64_t{detail::placeCodeChecksum(location_id, code.data(), code.size())}));
  markHeld(location_id, detail::kHeldPlaceCode, true);
  scope.commit();
}

std::vector<PlaceCodeRecord> PgMapStore::placeCodes() const {
  const auto r =
      db_->run("SELECT location_id, code, checksum FROM place_codes ORDER BY location_id");
  std::vector<PlaceCodeRecord> out;
  for (int i = 0; i < r.rows(); ++i) {
    const std::int64_t id = r.integer(i, 0);
    const auto [data, size] = r.bytes(i, 1);
    if (!sumMatches(r, i, 2, detail::placeCodeChecksum(id, data, size)))
      detail::refuseDamagedRow(label_, "place_codes", std::to_string(id), "fails its checksum");
    PlaceCodeRecord record{id, std::vector<std::int8_t>(size)};
    if (size) std::memcpy(record.code.data(), data, size);
    out.push_back(std::move(record));
  }
  return out;
}

std::optional<std::vector<std::int8_t>> PgMapStore::placeCode(std::int64_t location_id) const {
  const auto r = db_->run("SELECT code, checksum FROM place_codes WHERE location_id = $1",
                          detail::PgParams().add(location_id));
  if (r.rows() == 0) return std::nullopt;
  const auto [data, size] = r.bytes(0, 0);
  if (!sumMatches(r, 0, 1, detail::placeCodeChecksum(location_id, data, size)))
    detail::refuseDamagedRow(label_, "place_codes", std::to_string(location_id),
                             "fails its checksum");
  std::vector<std::int8_t> code(size);
  if (size) std::memcpy(code.data(), data, size);
  return code;
}

void PgMapStore::setWmAges(const std::vector<std::pair<std::int64_t, std::int64_t>>& ages) {
  auto scope = writeScope();
  if (ages.empty()) return scope.commit();
  // One row per location, the last given winning, as INSERT OR REPLACE in order does.
  std::map<std::int64_t, std::int64_t> last(ages.begin(), ages.end());
  for (const auto& [id, age] : ages) last[id] = age;
  std::vector<std::int64_t> ids, values;
  for (const auto& [id, age] : last) {
    ids.push_back(id);
    values.push_back(age);
  }
  if (side_session_) {
    sideSetWmAges(ids, values);
    return scope.commit();
  }
  std::vector<std::int64_t> sums;
  for (std::size_t i = 0; i < ids.size(); ++i)
    sums.push_back(detail::wmEntryChecksum(ids[i], values[i]));
  db_->send(
      "WITH e AS (INSERT INTO wm_entries (location_id, wm_age, checksum) SELECT * FROM "
      "unnest($1::int8[], $2::int8[], $3::int8[]) ON CONFLICT (location_id) DO UPDATE SET "
      "wm_age = excluded.wm_age, checksum = excluded.checksum) "
      "UPDATE locations SET held = held | $4 WHERE id = ANY($1) AND (held & $4) = 0",
      detail::PgParams().addArray(ids).addArray(values).addArray(sums).add(
          std::int64_t{detail::kHeldWmEntry}));
  scope.commit();
}

std::map<std::int64_t, std::int64_t> PgMapStore::wmAges() const {
  if (side_session_) return sideWmAges();
  const auto r = db_->run(
      "SELECT l.id, coalesce(w.wm_age, l.id) FROM locations l "
      "LEFT JOIN wm_entries w ON w.location_id = l.id");
  std::map<std::int64_t, std::int64_t> out;
  for (int i = 0; i < r.rows(); ++i) out.emplace(r.integer(i, 0), r.integer(i, 1));
  return out;
}

void PgMapStore::checkStoredRows() const {
  const auto refuse = [this](CheckFinding f) {
    detail::refuseDamagedRow(label_, f.table, f.row, f.problem);
  };
  {
    std::map<std::int64_t, std::map<std::string, std::string>> settings;
    const auto rows = db_->run("SELECT session_id, key, value FROM settings");
    for (int i = 0; i < rows.rows(); ++i)
      settings[rows.integer(i, 0)][rows.text(i, 1)] = rows.text(i, 2);
    const auto sessions = db_->run("SELECT id, source, settings_digest FROM sessions");
    for (int i = 0; i < sessions.rows(); ++i) {
      const std::int64_t id = sessions.integer(i, 0);
      if (sessions.optionalInteger(i, 2) !=
          std::int64_t{detail::settingsDigest(id, sessions.text(i, 1), settings[id])})
        refuse({"settings", "of session " + std::to_string(id),
                "do not match the session's settings_digest (a setting was deleted, added or "
                "changed, or the session's source)"});
    }
  }
  const auto r = db_->run(detail::locationRowFactsQuery().c_str());
  for (int i = 0; i < r.rows(); ++i) {
    detail::LocationRowFacts f;
    f.id = r.integer(i, 0);
    f.tier = r.optionalInteger(i, 1);
    f.held = r.optionalInteger(i, 2);
    f.has_digest = r.boolean(i, 3);
    f.place_code = r.boolean(i, 4);
    f.word_descriptors = r.boolean(i, 5);
    f.keypoints = r.boolean(i, 6);
    f.wm_entry = r.boolean(i, 7);
    f.wm_age = r.optionalInteger(i, 8).value_or(0);
    f.wm_checksum = r.optionalInteger(i, 9);
    f.session_id = r.integer(i, 10);
    f.weight = r.integer(i, 11);
    f.created_frame = r.optionalInteger(i, 12);
    f.checksum = r.optionalInteger(i, 13);
    detail::judgeLocationRow(f, refuse);
  }
  const auto links = db_->run(detail::linkCountQuery().c_str());
  for (int i = 0; i < links.rows(); ++i) {
    const std::string problem =
        detail::linkCountProblem(links.optionalInteger(i, 1), links.integer(i, 2));
    if (!problem.empty())
      refuse({"links", "of location " + std::to_string(links.integer(i, 0)), problem});
  }
  for (const char* table : {"place_codes", "wm_entries"}) {
    const auto orphans =
        db_->run((std::string("SELECT location_id FROM ") + table +
                  " o WHERE NOT EXISTS (SELECT 1 FROM locations l WHERE l.id = o.location_id)")
                     .c_str());
    if (orphans.rows() > 0)
      refuse({table, std::to_string(orphans.integer(0, 0)),
              "belongs to no location (its locations row is missing)"});
  }
}

// ---- Vocabulary imports ----

std::int64_t PgMapStore::recordVocabularyImport(const VocabularyImportRecord& v) {
  auto scope = writeScope();
  const std::int64_t id =
      db_->run(
             "INSERT INTO vocabulary_imports (id, session_id, file, checksum, word_count, mode, "
             "imported_at, extractor, distance_unit, settings) VALUES ((SELECT coalesce(max(id), "
             "0) + 1 FROM vocabulary_imports), $1, $2, $3, $4, $5, coalesce($6, to_char("
             "clock_timestamp() AT TIME ZONE 'UTC', 'YYYY-MM-DD\"T\"HH24:MI:SS.MS\"Z\"')), $7, "
             "$8, $9) RETURNING id",
             detail::PgParams()
                 .add(v.session_id)
                 .add(v.file)
                 .add(v.checksum)
                 .add(v.word_count)
                 .add(std::string(v.mode == VocabularyMode::kFixed ? "fixed" : "seed"))
                 .addText(v.imported_at.empty() ? std::nullopt
                                                : std::optional<std::string>(v.imported_at))
                 .add(v.extractor)
                 .add(v.distance_unit)
                 .add(nlohmann::json(v.settings).dump()))
          .integer(0, 0);
  scope.commit();
  return id;
}

std::vector<VocabularyImportRecord> PgMapStore::vocabularyImports() const {
  const auto r = db_->run(
      "SELECT id, session_id, file, checksum, word_count, mode, imported_at, "
      "coalesce(extractor, ''), coalesce(distance_unit, ''), settings "
      "FROM vocabulary_imports ORDER BY id");
  std::vector<VocabularyImportRecord> out;
  for (int i = 0; i < r.rows(); ++i) {
    VocabularyImportRecord v;
    v.id = r.integer(i, 0);
    v.session_id = r.optionalInteger(i, 1);
    v.file = r.text(i, 2);
    v.checksum = r.text(i, 3);
    v.word_count = r.integer(i, 4);
    v.mode = r.text(i, 5) == "fixed" ? VocabularyMode::kFixed : VocabularyMode::kSeed;
    v.imported_at = r.text(i, 6);
    v.extractor = r.text(i, 7);
    v.distance_unit = r.text(i, 8);
    if (!r.isNull(i, 9)) {
      const auto settings = nlohmann::json::parse(r.text(i, 9), nullptr, false);
      if (!settings.is_object())
        throw StorageError(ErrorCode::kMapRefused, "map " + label_ + ": vocabulary import " +
                                                       std::to_string(v.id) +
                                                       " has damaged settings (not a JSON object)");
      for (const auto& [key, value] : settings.items())
        if (value.is_string()) v.settings[key] = value.get<std::string>();
    }
    out.push_back(std::move(v));
  }
  return out;
}

}  // namespace placedb::storage
