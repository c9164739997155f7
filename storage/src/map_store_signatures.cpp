// MapStore: words, word references, links, hypotheses, engine state and vocabulary imports.
#include <algorithm>
#include <cstring>
#include <set>

#include <nlohmann/json.hpp>

#include "database.h"
#include "placedb/storage/map_store.h"
#include "write_scope.h"

namespace placedb::storage {
namespace {

std::size_t bytesPerValue(DescriptorKind type) { return type == DescriptorKind::kFloat32 ? 4 : 1; }

}  // namespace

// ---- Words ----

void MapStore::insertWords(const std::vector<WordRecord>& words) {
  WriteScope scope(*this);
  auto s = db_->cached(
      "INSERT INTO words (id, created_frame, vocabulary_import_id, descriptor_type, dim, "
      "descriptor, source_frame) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)");
  for (const WordRecord& w : words) {
    if (w.dim <= 0 ||
        w.descriptor.size() != static_cast<std::size_t>(w.dim) * bytesPerValue(w.type)) {
      throw StorageError(ErrorCode::kInvalidArgument,
                         "word " + std::to_string(w.id) + ": descriptor of " +
                             std::to_string(w.descriptor.size()) + " bytes does not match dim " +
                             std::to_string(w.dim));
    }
    s->bind(1, w.id);
    s->bind(2, w.created_frame);
    s->bind(3, w.vocabulary_import_id);
    s->bind(4, std::int64_t{static_cast<int>(w.type)});
    s->bind(5, std::int64_t{w.dim});
    s->bindBlob(6, w.descriptor.data(), w.descriptor.size());
    s->bind(7, w.source_frame);
    s->run();
  }
  scope.commit();
}

std::vector<WordRecord> MapStore::loadWords(const std::vector<std::int64_t>& word_ids) const {
  auto s = db_->cached(
      "SELECT id, created_frame, vocabulary_import_id, descriptor_type, dim, descriptor, "
      "source_frame FROM words WHERE id = ?1");
  std::vector<WordRecord> result;
  result.reserve(word_ids.size());
  for (std::int64_t id : word_ids) {
    s->reset();
    s->bind(1, id);
    if (!s->step()) continue;
    WordRecord w;
    w.id = s->columnInt(0);
    w.created_frame = s->columnOptionalInt(1);
    w.vocabulary_import_id = s->columnOptionalInt(2);
    w.type = static_cast<DescriptorKind>(s->columnInt(3));
    w.dim = static_cast<int>(s->columnInt(4));
    w.descriptor = s->columnBlob(5);
    w.source_frame = s->columnOptionalInt(6);
    result.push_back(std::move(w));
  }
  return result;
}

void MapStore::loadFloatDescriptors(const std::vector<std::int64_t>& word_ids, int dim, float* rows,
                                    std::int64_t* created) const {
  if (!std::is_sorted(word_ids.begin(), word_ids.end()))
    throw StorageError(ErrorCode::kInvalidArgument, "loadFloatDescriptors: ids must be sorted");
  // Word ids rise with creation, and the words of working memory are mostly runs of recent ones:
  // walking the table in id order and seeking again only across a gap costs far less than one
  // B-tree descent per word.
  constexpr int kMaxSkipped = 16;
  auto s = db_->cached(
      "SELECT id, created_frame, descriptor_type, dim, descriptor FROM words WHERE id >= ?1 "
      "ORDER BY id");
  const std::size_t row_bytes = static_cast<std::size_t>(dim) * sizeof(float);
  auto missing = [&](std::int64_t id) {
    return StorageError(ErrorCode::kMapRefused,
                        "map " + path_ + ": word " + std::to_string(id) + " is missing");
  };
  std::size_t i = 0;
  while (i < word_ids.size()) {
    s->reset();
    s->bind(1, word_ids[i]);
    int skipped = 0;
    while (i < word_ids.size() && skipped <= kMaxSkipped) {
      if (!s->step()) throw missing(word_ids[i]);
      const std::int64_t id = s->columnInt(0);
      if (id < word_ids[i]) {
        ++skipped;
        continue;
      }
      if (id > word_ids[i]) throw missing(word_ids[i]);
      const auto [data, size] = s->columnBlobView(4);
      if (static_cast<DescriptorKind>(s->columnInt(2)) != DescriptorKind::kFloat32 ||
          s->columnInt(3) != dim || size != row_bytes)
        throw StorageError(ErrorCode::kMapRefused, "map " + path_ + ": word " + std::to_string(id) +
                                                       " is not a float descriptor of dimension " +
                                                       std::to_string(dim));
      std::memcpy(rows + i * static_cast<std::size_t>(dim), data, row_bytes);
      created[i] = s->isNull(1) ? -1 : s->columnInt(1);
      ++i;
      skipped = 0;
    }
  }
}

std::int64_t MapStore::wordCount() const {
  auto s = db_->cached("SELECT count(*) FROM words");
  s->step();
  return s->columnInt(0);
}

std::optional<std::int64_t> MapStore::maxWordId() const {
  auto s = db_->cached("SELECT max(id) FROM words");
  s->step();
  return s->columnOptionalInt(0);
}

// ---- Word references ----

void MapStore::insertWordRefs(std::int64_t location_id, const std::vector<WordRef>& refs) {
  WriteScope scope(*this);
  std::int64_t ordinal = 0;
  {
    auto s = db_->cached("SELECT max(ordinal) FROM word_refs WHERE location_id = ?1");
    s->bind(1, location_id);
    s->step();
    if (!s->isNull(0)) ordinal = s->columnInt(0) + 1;
  }
  auto s = db_->cached(
      "INSERT INTO word_refs (location_id, ordinal, word_id, x, y, size, angle, response) "
      "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)");
  for (const WordRef& r : refs) {
    s->bind(1, location_id);
    s->bind(2, ordinal++);
    s->bind(3, r.word_id);
    s->bind(4, double{r.x});
    s->bind(5, double{r.y});
    s->bind(6, double{r.size});
    s->bind(7, double{r.angle});
    s->bind(8, double{r.response});
    s->run();
  }
  scope.commit();
}

void MapStore::replaceWordRefs(std::int64_t location_id, const std::vector<WordRef>& refs) {
  WriteScope scope(*this);
  {
    auto s = db_->cached("DELETE FROM word_refs WHERE location_id = ?1");
    s->bind(1, location_id);
    s->run();
  }
  insertWordRefs(location_id, refs);
  scope.commit();
}

std::vector<WordRef> MapStore::loadWordRefs(std::int64_t location_id) const {
  auto s = db_->cached(
      "SELECT word_id, x, y, size, angle, response FROM word_refs WHERE location_id = ?1 "
      "ORDER BY ordinal");
  s->bind(1, location_id);
  std::vector<WordRef> result;
  while (s->step()) {
    result.push_back(
        WordRef{s->columnInt(0), static_cast<float>(s->columnDouble(1)),
                static_cast<float>(s->columnDouble(2)), static_cast<float>(s->columnDouble(3)),
                static_cast<float>(s->columnDouble(4)), static_cast<float>(s->columnDouble(5))});
  }
  return result;
}

std::map<std::int64_t, std::vector<WordRef>> MapStore::loadWordRefs(
    const std::vector<std::int64_t>& location_ids) const {
  std::map<std::int64_t, std::vector<WordRef>> result;
  for (std::int64_t id : location_ids) result[id] = loadWordRefs(id);
  return result;
}

std::map<std::int64_t, std::vector<std::int64_t>> MapStore::loadWordIds(
    const std::vector<std::int64_t>& location_ids) const {
  auto s = db_->cached("SELECT word_id FROM word_refs WHERE location_id = ?1 ORDER BY ordinal");
  std::map<std::int64_t, std::vector<std::int64_t>> result;
  for (std::int64_t id : location_ids) {
    s->reset();
    s->bind(1, id);
    auto& ids = result[id];
    while (s->step()) ids.push_back(s->columnInt(0));
  }
  return result;
}

std::vector<std::int64_t> MapStore::importedWordIds() const {
  // Read on every open: the partial index words_imported serves it without a scan of the whole
  // vocabulary (millions of words on a long map).
  auto s = db_->cached(
      "SELECT id FROM words INDEXED BY words_imported WHERE vocabulary_import_id IS NOT NULL "
      "ORDER BY id");
  std::vector<std::int64_t> ids;
  while (s->step()) ids.push_back(s->columnInt(0));
  return ids;
}

std::vector<std::int64_t> MapStore::wordsOfLocations(
    const std::vector<std::int64_t>& location_ids) const {
  auto s = db_->cached("SELECT word_id FROM word_refs WHERE location_id = ?1");
  std::set<std::int64_t> words;
  for (std::int64_t id : location_ids) {
    s->reset();
    s->bind(1, id);
    while (s->step()) words.insert(s->columnInt(0));
  }
  return {words.begin(), words.end()};
}

std::vector<std::int64_t> MapStore::locationsOfWord(std::int64_t word_id) const {
  auto s = db_->cached(
      "SELECT DISTINCT location_id FROM word_refs WHERE word_id = ?1 ORDER BY location_id");
  s->bind(1, word_id);
  std::vector<std::int64_t> result;
  while (s->step()) result.push_back(s->columnInt(0));
  return result;
}

// ---- Links ----

void MapStore::insertLink(std::int64_t a, std::int64_t b, LinkType type,
                          std::optional<double> score) {
  if (a == b) {
    throw StorageError(ErrorCode::kInvalidArgument,
                       "link of location " + std::to_string(a) + " to itself");
  }
  WriteScope scope(*this);
  auto s = db_->cached(
      "INSERT INTO links (location_a, location_b, type, score) VALUES (?1, ?2, ?3, ?4) "
      "ON CONFLICT (location_a, location_b, type) DO UPDATE SET score = excluded.score");
  s->bind(1, std::min(a, b));
  s->bind(2, std::max(a, b));
  s->bind(3, std::int64_t{static_cast<int>(type)});
  s->bind(4, score);
  s->run();
  scope.commit();
}

std::vector<LinkRecord> MapStore::links(std::int64_t location_id) const {
  auto s = db_->cached(
      "SELECT location_a, location_b, type, score FROM links WHERE location_a = ?1 "
      "UNION ALL SELECT location_a, location_b, type, score FROM links WHERE location_b = ?1 "
      "ORDER BY 1, 2, 3");
  s->bind(1, location_id);
  std::vector<LinkRecord> result;
  while (s->step()) {
    result.push_back({s->columnInt(0), s->columnInt(1), static_cast<LinkType>(s->columnInt(2)),
                      s->columnOptionalDouble(3)});
  }
  return result;
}

std::vector<std::int64_t> MapStore::linkedInTier(std::int64_t location_id, Tier tier,
                                                 std::optional<LinkType> type) const {
  auto s = db_->cached(
      "SELECT DISTINCT k.other FROM ("
      "  SELECT location_b AS other, type FROM links WHERE location_a = ?1"
      "  UNION ALL SELECT location_a, type FROM links WHERE location_b = ?1) k "
      "JOIN locations l ON l.id = k.other "
      "WHERE l.tier = ?2 AND (?3 IS NULL OR k.type = ?3) ORDER BY k.other");
  s->bind(1, location_id);
  s->bind(2, std::int64_t{static_cast<int>(tier)});
  if (type) s->bind(3, std::int64_t{static_cast<int>(*type)});
  std::vector<std::int64_t> result;
  while (s->step()) result.push_back(s->columnInt(0));
  return result;
}

// ---- Hypotheses ----

void MapStore::insertHypothesis(const HypothesisRecord& h) {
  WriteScope scope(*this);
  auto s = db_->cached(
      "INSERT INTO hypotheses (frame_id, best_location_id, posterior, loop_probability, "
      "accepted, rejected_reason) VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
  s->bind(1, h.frame_id);
  s->bind(2, h.best_location_id);
  s->bind(3, h.posterior);
  s->bind(4, h.loop_probability);
  s->bind(5, std::int64_t{h.accepted ? 1 : 0});
  if (!h.rejected_reason.empty()) s->bind(6, h.rejected_reason);
  s->run();
  scope.commit();
}

std::optional<HypothesisRecord> MapStore::hypothesis(std::int64_t frame_id) const {
  auto s = db_->cached(
      "SELECT frame_id, best_location_id, posterior, loop_probability, accepted, "
      "rejected_reason FROM hypotheses WHERE frame_id = ?1");
  s->bind(1, frame_id);
  if (!s->step()) return std::nullopt;
  return HypothesisRecord{s->columnInt(0),    s->columnOptionalInt(1), s->columnDouble(2),
                          s->columnDouble(3), s->columnInt(4) != 0,    s->columnText(5)};
}

// ---- Engine state ----

void MapStore::putState(const std::string& key, const std::vector<std::uint8_t>& value) {
  WriteScope scope(*this);
  auto s = db_->cached(
      "INSERT INTO engine_state (key, value) VALUES (?1, ?2) "
      "ON CONFLICT (key) DO UPDATE SET value = excluded.value");
  s->bind(1, key);
  s->bindBlob(2, value.data(), value.size());
  s->run();
  scope.commit();
}

void MapStore::putState(const std::string& key, const std::string& value) {
  WriteScope scope(*this);
  auto s = db_->cached(
      "INSERT INTO engine_state (key, value) VALUES (?1, ?2) "
      "ON CONFLICT (key) DO UPDATE SET value = excluded.value");
  s->bind(1, key);
  s->bind(2, value);
  s->run();
  scope.commit();
}

std::optional<std::vector<std::uint8_t>> MapStore::getState(const std::string& key) const {
  auto s = db_->cached("SELECT value FROM engine_state WHERE key = ?1");
  s->bind(1, key);
  if (!s->step()) return std::nullopt;
  return s->columnBlob(0);
}

std::optional<std::string> MapStore::getStateText(const std::string& key) const {
  auto s = db_->cached("SELECT value FROM engine_state WHERE key = ?1");
  s->bind(1, key);
  if (!s->step()) return std::nullopt;
  return s->columnText(0);
}

void MapStore::deleteState(const std::string& key) {
  WriteScope scope(*this);
  auto s = db_->cached("DELETE FROM engine_state WHERE key = ?1");
  s->bind(1, key);
  s->run();
  scope.commit();
}

void MapStore::writeKdNodes(const std::vector<KdNodeRecord>& upserts,
                            const std::vector<std::pair<int, std::int64_t>>& deletions,
                            bool replace_all) {
  WriteScope scope(*this);
  if (replace_all) {
    auto s = db_->cached("DELETE FROM kd_nodes");
    s->run();
  }
  if (!deletions.empty()) {
    auto s = db_->cached("DELETE FROM kd_nodes WHERE tree = ?1 AND node = ?2");
    for (const auto& [tree, node] : deletions) {
      s->bind(1, std::int64_t(tree));
      s->bind(2, node);
      s->run();
    }
  }
  if (!upserts.empty()) {
    auto s = db_->cached(
        "INSERT INTO kd_nodes (tree, node, left_child, right_child, split_dim, split_value) "
        "VALUES (?1, ?2, ?3, ?4, ?5, ?6) ON CONFLICT (tree, node) DO UPDATE SET "
        "left_child = excluded.left_child, right_child = excluded.right_child, "
        "split_dim = excluded.split_dim, split_value = excluded.split_value");
    for (const KdNodeRecord& n : upserts) {
      s->bind(1, std::int64_t(n.tree));
      s->bind(2, n.node);
      s->bind(3, n.left_child);
      s->bind(4, n.right_child);
      s->bind(5, std::int64_t(n.split_dim));
      s->bind(6, n.split_value);
      s->run();
    }
  }
  scope.commit();
}

std::vector<KdNodeRecord> MapStore::loadKdNodes() const {
  std::vector<KdNodeRecord> out;
  auto s = db_->cached(
      "SELECT tree, node, left_child, right_child, split_dim, split_value FROM kd_nodes "
      "ORDER BY tree, node");
  while (s->step()) {
    KdNodeRecord n;
    n.tree = static_cast<int>(s->columnInt(0));
    n.node = s->columnInt(1);
    n.left_child = s->columnInt(2);
    n.right_child = s->columnInt(3);
    n.split_dim = static_cast<int>(s->columnInt(4));
    n.split_value = s->columnDouble(5);
    out.push_back(n);
  }
  return out;
}

void MapStore::putPosterior(const std::vector<std::pair<std::int64_t, double>>& posterior) {
  WriteScope scope(*this);
  {
    auto s = db_->cached("DELETE FROM filter_posterior");
    s->run();
  }
  auto s = db_->cached("INSERT INTO filter_posterior (location_id, probability) VALUES (?1, ?2)");
  for (const auto& [location_id, probability] : posterior) {
    s->bind(1, location_id);
    s->bind(2, probability);
    s->run();
  }
  scope.commit();
}

std::vector<std::pair<std::int64_t, double>> MapStore::loadPosterior() const {
  auto s =
      db_->cached("SELECT location_id, probability FROM filter_posterior ORDER BY location_id");
  std::vector<std::pair<std::int64_t, double>> result;
  while (s->step()) result.emplace_back(s->columnInt(0), s->columnDouble(1));
  return result;
}

// ---- Vocabulary imports ----

std::int64_t MapStore::recordVocabularyImport(const VocabularyImportRecord& v) {
  WriteScope scope(*this);
  auto s = db_->cached(
      "INSERT INTO vocabulary_imports (session_id, file, checksum, word_count, mode, imported_at, "
      "extractor, distance_unit, settings) "
      "VALUES (?1, ?2, ?3, ?4, ?5, coalesce(?6, strftime('%Y-%m-%dT%H:%M:%fZ', 'now')), ?7, ?8, "
      "?9)");
  s->bind(1, v.session_id);
  s->bind(2, v.file);
  s->bind(3, v.checksum);
  s->bind(4, v.word_count);
  s->bind(5, std::string(v.mode == VocabularyMode::kFixed ? "fixed" : "seed"));
  if (!v.imported_at.empty()) s->bind(6, v.imported_at);
  s->bind(7, v.extractor);
  s->bind(8, v.distance_unit);
  s->bind(9, nlohmann::json(v.settings).dump());
  s->run();
  const std::int64_t id = sqlite3_last_insert_rowid(db_->handle());
  scope.commit();
  return id;
}

std::vector<VocabularyImportRecord> MapStore::vocabularyImports() const {
  auto s = db_->cached(
      "SELECT id, session_id, file, checksum, word_count, mode, imported_at, "
      "coalesce(extractor, ''), coalesce(distance_unit, ''), settings "
      "FROM vocabulary_imports ORDER BY id");
  std::vector<VocabularyImportRecord> result;
  while (s->step()) {
    VocabularyImportRecord v;
    v.id = s->columnInt(0);
    v.session_id = s->columnOptionalInt(1);
    v.file = s->columnText(2);
    v.checksum = s->columnText(3);
    v.word_count = s->columnInt(4);
    v.mode = s->columnText(5) == "fixed" ? VocabularyMode::kFixed : VocabularyMode::kSeed;
    v.imported_at = s->columnText(6);
    v.extractor = s->columnText(7);
    v.distance_unit = s->columnText(8);
    if (!s->isNull(9)) {
      const auto settings = nlohmann::json::parse(s->columnText(9), nullptr, false);
      if (!settings.is_object())
        throw StorageError(ErrorCode::kMapRefused, "map " + path_ + ": vocabulary import " +
                                                       std::to_string(v.id) +
                                                       " has damaged settings (not a JSON object)");
      for (const auto& [key, value] : settings.items())
        if (value.is_string()) v.settings[key] = value.get<std::string>();
    }
    result.push_back(std::move(v));
  }
  return result;
}

}  // namespace placedb::storage
