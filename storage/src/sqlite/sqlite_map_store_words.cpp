// MapStore: the words of the vocabulary and the word references that make each location's
// signature.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>
#include <string>

#include "placedb/storage/sqlite_map_store.h"
#include "sqlite/database.h"
#include "sqlite/sqlite_checksums.h"
#include "sqlite/sqlite_location_rows.h"
#include "sqlite/sqlite_rows.h"

namespace placedb::storage {
namespace {

std::size_t bytesPerValue(DescriptorKind type) { return type == DescriptorKind::kFloat32 ? 4 : 1; }

}  // namespace

// ---- Words ----

void SqliteMapStore::insertWords(const std::vector<WordRecord>& words) {
  auto scope = writeScope();
  for (const WordRecord& w : words) {
    if (w.dim <= 0 ||
        w.descriptor.size() != static_cast<std::size_t>(w.dim) * bytesPerValue(w.type)) {
      throw StorageError(ErrorCode::kInvalidArgument,
                         "word " + std::to_string(w.id) + ": descriptor of " +
                             std::to_string(w.descriptor.size()) + " bytes does not match dim " +
                             std::to_string(w.dim));
    }
  }
  static const detail::RowInserts sql("INSERT",
                                      "words (id, created_frame, vocabulary_import_id, "
                                      "descriptor_type, dim, descriptor, source_frame, checksum)",
                                      8);
  detail::insertRows(*db_, sql, words.size(), [&](detail::Statement& s, int at, std::size_t i) {
    const WordRecord& w = words[i];
    s.bind(at + 1, w.id);
    s.bind(at + 2, w.created_frame);
    s.bind(at + 3, w.vocabulary_import_id);
    s.bind(at + 4, std::int64_t{static_cast<int>(w.type)});
    s.bind(at + 5, std::int64_t{w.dim});
    s.bindBlob(at + 6, w.descriptor.data(), w.descriptor.size());
    s.bind(at + 7, w.source_frame);
    s.bind(at + 8,
           std::int64_t{detail::wordChecksum(w.id, w.created_frame, static_cast<int>(w.type), w.dim,
                                             w.descriptor.data(), w.descriptor.size())});
  });
  scope.commit();
}

std::vector<WordRecord> SqliteMapStore::loadWords(const std::vector<std::int64_t>& word_ids) const {
  auto s = db_->cached(
      "SELECT id, created_frame, vocabulary_import_id, descriptor_type, dim, descriptor, "
      "source_frame, checksum FROM words WHERE id = ?1");
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
    if (!detail::checksumMatches(*s, 7,
                                 detail::wordChecksum(w.id, w.created_frame, s->columnInt(3), w.dim,
                                                      w.descriptor.data(), w.descriptor.size())))
      detail::refuseDamagedRow(path_, "words", std::to_string(w.id), "fails its checksum");
    result.push_back(std::move(w));
  }
  return result;
}

void SqliteMapStore::loadFloatDescriptors(const std::vector<std::int64_t>& word_ids, int dim,
                                          float* rows, std::int64_t* created) const {
  if (!std::is_sorted(word_ids.begin(), word_ids.end()))
    throw StorageError(ErrorCode::kInvalidArgument, "loadFloatDescriptors: ids must be sorted");
  // Word ids rise with creation, and the words of working memory are mostly runs of recent ones:
  // walking the table in id order and seeking again only across a gap costs far less than one
  // B-tree descent per word.
  constexpr int kMaxSkipped = 16;
  auto s = db_->cached(
      "SELECT id, created_frame, descriptor_type, dim, descriptor, checksum FROM words "
      "WHERE id >= ?1 ORDER BY id");
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
      if (!detail::checksumMatches(
              *s, 5,
              detail::wordChecksum(id, s->columnOptionalInt(1), s->columnInt(2), dim, data, size)))
        detail::refuseDamagedRow(path_, "words", std::to_string(id), "fails its checksum");
      float* row = rows + i * static_cast<std::size_t>(dim);
      std::memcpy(row, data, row_bytes);
      // A word written with a NaN or infinity (by a placedb before checksums) would poison every
      // distance to it; no extractor makes one.
      for (int d = 0; d < dim; ++d)
        if (!std::isfinite(row[d]))
          detail::refuseDamagedRow(path_, "words", std::to_string(id),
                                   "holds a value that is not a finite number");
      created[i] = s->isNull(1) ? -1 : s->columnInt(1);
      ++i;
      skipped = 0;
    }
  }
}

void SqliteMapStore::putLocationWordDescriptors(const LocationWordDescriptors& words) {
  auto scope = writeScope();
  const std::vector<std::uint8_t> bytes = words.encode();
  auto s = db_->cached(
      "INSERT OR REPLACE INTO location_word_descriptors (location_id, dim, words, checksum) "
      "VALUES (?1, ?2, ?3, ?4)");
  s->bind(1, words.location_id);
  s->bind(2, std::int64_t{words.dim});
  s->bindBlob(3, bytes.data(), bytes.size());
  s->bind(4, std::int64_t{detail::locationWordDescriptorsChecksum(words.location_id, words.dim,
                                                                  bytes.data(), bytes.size())});
  s->run();
  markHeld(words.location_id, detail::kHeldWordDescriptors, true);
  scope.commit();
}

std::vector<LocationWordDescriptors> SqliteMapStore::locationWordDescriptors(
    const std::vector<std::int64_t>& location_ids) const {
  auto s = db_->cached(
      "SELECT dim, words, checksum FROM location_word_descriptors WHERE location_id = ?1");
  std::vector<LocationWordDescriptors> result;
  for (std::int64_t id : location_ids) {
    s->reset();
    s->bind(1, id);
    if (!s->step()) continue;
    const auto [data, size] = s->columnBlobView(1);
    const std::int64_t dim = s->columnInt(0);
    if (!detail::checksumMatches(*s, 2,
                                 detail::locationWordDescriptorsChecksum(id, dim, data, size)))
      detail::refuseDamagedRow(path_, "location_word_descriptors", std::to_string(id),
                               "fails its checksum");
    LocationWordDescriptors words;
    const std::string fault = detail::locationWordDescriptorsFault(id, dim, data, size, &words);
    if (!fault.empty())
      detail::refuseDamagedRow(path_, "location_word_descriptors", std::to_string(id), fault);
    result.push_back(std::move(words));
  }
  return result;
}

std::int64_t SqliteMapStore::wordCount() const {
  auto s = db_->cached("SELECT count(*) FROM words");
  s->step();
  return s->columnInt(0);
}

std::optional<std::int64_t> SqliteMapStore::maxWordId() const {
  auto s = db_->cached("SELECT max(id) FROM words");
  s->step();
  return s->columnOptionalInt(0);
}

// ---- Word references ----

void SqliteMapStore::insertWordRefs(std::int64_t location_id, const std::vector<WordRef>& refs) {
  auto scope = writeScope();
  std::int64_t ordinal = 0;
  {
    auto s = db_->cached("SELECT max(ordinal) FROM word_refs WHERE location_id = ?1");
    s->bind(1, location_id);
    s->step();
    if (!s->isNull(0)) ordinal = s->columnInt(0) + 1;
  }
  static const detail::RowInserts sql(
      "INSERT", "word_refs (location_id, ordinal, word_id, x, y, size, angle, response)", 8);
  detail::insertRows(*db_, sql, refs.size(), [&](detail::Statement& s, int at, std::size_t i) {
    const WordRef& r = refs[i];
    s.bind(at + 1, location_id);
    s.bind(at + 2, ordinal + static_cast<std::int64_t>(i));
    s.bind(at + 3, r.word_id);
    s.bind(at + 4, double{r.x});
    s.bind(at + 5, double{r.y});
    s.bind(at + 6, double{r.size});
    s.bind(at + 7, double{r.angle});
    s.bind(at + 8, double{r.response});
  });
  // The digest of the whole signature: the rows just written, after those already there (a
  // signature is written once by the engine; appending reads the earlier rows back).
  const std::uint32_t digest =
      ordinal == 0 ? detail::refsDigest(location_id, refs)
                   : detail::refsDigest(location_id, readWordRefs(location_id, nullptr));
  auto update = db_->cached("UPDATE locations SET refs_digest = ?2 WHERE id = ?1");
  update->bind(1, location_id);
  update->bind(2, std::int64_t{digest});
  update->run();
  scope.commit();
}

void SqliteMapStore::replaceWordRefs(std::int64_t location_id, const std::vector<WordRef>& refs) {
  auto scope = writeScope();
  {
    auto s = db_->cached("DELETE FROM word_refs WHERE location_id = ?1");
    s->bind(1, location_id);
    s->run();
  }
  insertWordRefs(location_id, refs);
  scope.commit();
}

std::vector<WordRef> SqliteMapStore::readWordRefs(std::int64_t location_id,
                                                  detail::RefsDigest* digest) const {
  auto s = db_->cached(
      "SELECT word_id, x, y, size, angle, response, ordinal FROM word_refs WHERE location_id = ?1 "
      "ORDER BY ordinal");
  s->bind(1, location_id);
  std::vector<WordRef> result;
  while (s->step()) {
    const double x = s->columnDouble(1), y = s->columnDouble(2), size = s->columnDouble(3),
                 angle = s->columnDouble(4), response = s->columnDouble(5);
    if (digest) {
      const std::string fault = detail::refValueFault(x, y, size, angle, response);
      if (!fault.empty())
        detail::refuseDamagedRow(
            path_, "word_refs",
            "(" + std::to_string(location_id) + ", " + std::to_string(s->columnInt(6)) + ")",
            fault);
      digest->add(s->columnInt(0), x, y, size, angle, response);
    }
    result.push_back(WordRef{s->columnInt(0), static_cast<float>(x), static_cast<float>(y),
                             static_cast<float>(size), static_cast<float>(angle),
                             static_cast<float>(response)});
  }
  return result;
}

void SqliteMapStore::requireRefsDigest(std::int64_t location_id,
                                       const detail::RefsDigest& digest) const {
  auto s = db_->cached("SELECT refs_digest FROM locations WHERE id = ?1");
  s->bind(1, location_id);
  if (!s->step()) {
    if (digest.count() == 0) return;  // no location, no references: nothing was read
    detail::refuseDamagedRow(path_, "locations", std::to_string(location_id),
                             "is missing (its word_refs are read)");
  }
  if (!detail::checksumMatches(*s, 0, digest.value()))
    detail::refuseDamagedRow(path_, "word_refs", "of location " + std::to_string(location_id),
                             "do not match the location's refs_digest (" +
                                 std::to_string(digest.count()) +
                                 " rows: a reference was deleted, added or changed)");
}

std::vector<WordRef> SqliteMapStore::loadWordRefs(std::int64_t location_id) const {
  detail::RefsDigest digest(location_id);
  std::vector<WordRef> refs = readWordRefs(location_id, &digest);
  requireRefsDigest(location_id, digest);
  return refs;
}

std::map<std::int64_t, std::vector<WordRef>> SqliteMapStore::loadWordRefs(
    const std::vector<std::int64_t>& location_ids) const {
  std::map<std::int64_t, std::vector<WordRef>> result;
  for (std::int64_t id : location_ids) result[id] = loadWordRefs(id);
  return result;
}

std::map<std::int64_t, std::vector<std::int64_t>> SqliteMapStore::loadWordIds(
    const std::vector<std::int64_t>& location_ids) const {
  // The whole references are read, to check them against the location's digest: a signature is
  // what every later frame is compared with.
  std::map<std::int64_t, std::vector<std::int64_t>> result;
  for (std::int64_t id : location_ids) {
    auto& ids = result[id];
    for (const WordRef& r : loadWordRefs(id)) ids.push_back(r.word_id);
  }
  return result;
}

std::vector<std::int64_t> SqliteMapStore::importedWordIds() const {
  // Read on every open: the partial index words_imported serves it without a scan of the whole
  // vocabulary (millions of words on a long map).
  auto s = db_->cached(
      "SELECT id FROM words INDEXED BY words_imported WHERE vocabulary_import_id IS NOT NULL "
      "ORDER BY id");
  std::vector<std::int64_t> ids;
  while (s->step()) ids.push_back(s->columnInt(0));
  return ids;
}

std::vector<std::int64_t> SqliteMapStore::wordsOfLocations(
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

std::vector<std::int64_t> SqliteMapStore::locationsOfWord(std::int64_t word_id) const {
  auto s = db_->cached(
      "SELECT DISTINCT location_id FROM word_refs WHERE word_id = ?1 ORDER BY location_id");
  s->bind(1, word_id);
  std::vector<std::int64_t> result;
  while (s->step()) result.push_back(s->columnInt(0));
  return result;
}

}  // namespace placedb::storage
