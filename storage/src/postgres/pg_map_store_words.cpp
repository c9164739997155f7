// PgMapStore: words, word references (signatures), links and loop-closure hypotheses.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <unordered_map>

#include "location_rows.h"
#include "postgres/pg_map_store.h"
#include "row_checksums.h"

namespace placedb::storage {
namespace {

std::size_t bytesPerValue(DescriptorKind type) { return type == DescriptorKind::kFloat32 ? 4 : 1; }

bool sumMatches(const detail::PgResult& r, int row, int column, std::uint32_t computed) {
  return !r.isNull(row, column) && r.integer(row, column) == std::int64_t{computed};
}

std::vector<WordRef> readRefs(const detail::PgResult& r, int first_row, int end_row, int column) {
  std::vector<WordRef> out;
  for (int i = first_row; i < end_row; ++i)
    out.push_back(WordRef{
        r.integer(i, column), static_cast<float>(r.real(i, column + 1)),
        static_cast<float>(r.real(i, column + 2)), static_cast<float>(r.real(i, column + 3)),
        static_cast<float>(r.real(i, column + 4)), static_cast<float>(r.real(i, column + 5))});
  return out;
}

}  // namespace

// ---- Words ----

void PgMapStore::insertWords(const std::vector<WordRecord>& words) {
  auto scope = writeScope();
  if (words.empty()) return scope.commit();
  std::vector<std::int64_t> ids, types, dims, sums;
  std::vector<std::optional<std::int64_t>> created, imports, sources;
  std::vector<std::pair<const void*, std::size_t>> descriptors;
  for (const WordRecord& w : words) {
    if (w.dim <= 0 ||
        w.descriptor.size() != static_cast<std::size_t>(w.dim) * bytesPerValue(w.type)) {
      throw StorageError(ErrorCode::kInvalidArgument,
                         "word " + std::to_string(w.id) + ": descriptor of " +
                             std::to_string(w.descriptor.size()) + " bytes does not match dim " +
                             std::to_string(w.dim));
    }
    ids.push_back(w.id);
    created.push_back(w.created_frame);
    imports.push_back(w.vocabulary_import_id);
    types.push_back(static_cast<int>(w.type));
    dims.push_back(w.dim);
    descriptors.emplace_back(w.descriptor.data(), w.descriptor.size());
    sources.push_back(w.source_frame);
    sums.push_back(detail::wordChecksum(w.id, w.created_frame, static_cast<int>(w.type), w.dim,
                                        w.descriptor.data(), w.descriptor.size()));
  }
  db_->send(
      "INSERT INTO words (id, created_frame, vocabulary_import_id, descriptor_type, dim, "
      "descriptor, source_frame, checksum) SELECT * FROM unnest($1::int8[], $2::int8[], "
      "$3::int8[], $4::int8[], $5::int8[], $6::bytea[], $7::int8[], $8::int8[])",
      detail::PgParams()
          .addArray(ids)
          .addArray(created)
          .addArray(imports)
          .addArray(types)
          .addArray(dims)
          .addBytesArray(descriptors)
          .addArray(sources)
          .addArray(sums));
  scope.commit();
}

std::vector<WordRecord> PgMapStore::loadWords(const std::vector<std::int64_t>& word_ids) const {
  const auto r = db_->run(
      "SELECT id, created_frame, vocabulary_import_id, descriptor_type, dim, descriptor, "
      "source_frame, checksum FROM words WHERE id = ANY($1)",
      detail::PgParams().addArray(word_ids));
  std::unordered_map<std::int64_t, int> row_of;
  for (int i = 0; i < r.rows(); ++i) row_of[r.integer(i, 0)] = i;
  std::vector<WordRecord> out;
  out.reserve(word_ids.size());
  for (std::int64_t id : word_ids) {
    const auto found = row_of.find(id);
    if (found == row_of.end()) continue;
    const int i = found->second;
    WordRecord w;
    w.id = id;
    w.created_frame = r.optionalInteger(i, 1);
    w.vocabulary_import_id = r.optionalInteger(i, 2);
    w.type = static_cast<DescriptorKind>(r.integer(i, 3));
    w.dim = static_cast<int>(r.integer(i, 4));
    const auto [data, size] = r.bytes(i, 5);
    w.descriptor.assign(data, data + size);
    w.source_frame = r.optionalInteger(i, 6);
    if (!sumMatches(r, i, 7,
                    detail::wordChecksum(id, w.created_frame, r.integer(i, 3), w.dim, data, size)))
      detail::refuseDamagedRow(label_, "words", std::to_string(id), "fails its checksum");
    out.push_back(std::move(w));
  }
  return out;
}

void PgMapStore::loadFloatDescriptors(const std::vector<std::int64_t>& word_ids, int dim,
                                      float* rows, std::int64_t* created) const {
  if (!std::is_sorted(word_ids.begin(), word_ids.end()))
    throw StorageError(ErrorCode::kInvalidArgument, "loadFloatDescriptors: ids must be sorted");
  // Ids that fill most of their range (the words of a writer's working memory at its open: 95 %
  // of it, fleet bench) are read as the range, rows in id order, and the others skipped here: an
  // index probe each cost the server 2.2 us a word asked, the range 1.4.
  const bool dense = !word_ids.empty() && word_ids.back() - word_ids.front() <
                                              2 * static_cast<std::int64_t>(word_ids.size());
  const auto r =
      dense ? db_->run(
                  "SELECT id, created_frame, descriptor_type, dim, descriptor, checksum FROM "
                  "words WHERE id BETWEEN $1 AND $2 ORDER BY id",
                  detail::PgParams().add(word_ids.front()).add(word_ids.back()))
            : db_->run(
                  "SELECT id, created_frame, descriptor_type, dim, descriptor, checksum FROM "
                  "words WHERE id = ANY($1) ORDER BY id",
                  detail::PgParams().addArray(word_ids));
  const std::size_t row_bytes = static_cast<std::size_t>(dim) * sizeof(float);
  int at = 0;
  for (std::size_t i = 0; i < word_ids.size(); ++i) {
    const std::int64_t id = word_ids[i];
    while (at < r.rows() && r.integer(at, 0) < id) ++at;
    if (at >= r.rows() || r.integer(at, 0) != id)
      throw StorageError(ErrorCode::kMapRefused,
                         "map " + label_ + ": word " + std::to_string(id) + " is missing");
    const auto [data, size] = r.bytes(at, 4);
    if (static_cast<DescriptorKind>(r.integer(at, 2)) != DescriptorKind::kFloat32 ||
        r.integer(at, 3) != dim || size != row_bytes)
      throw StorageError(ErrorCode::kMapRefused, "map " + label_ + ": word " + std::to_string(id) +
                                                     " is not a float descriptor of dimension " +
                                                     std::to_string(dim));
    if (!sumMatches(
            r, at, 5,
            detail::wordChecksum(id, r.optionalInteger(at, 1), r.integer(at, 2), dim, data, size)))
      detail::refuseDamagedRow(label_, "words", std::to_string(id), "fails its checksum");
    float* row = rows + i * static_cast<std::size_t>(dim);
    std::memcpy(row, data, row_bytes);
    for (int d = 0; d < dim; ++d)
      if (!std::isfinite(row[d]))
        detail::refuseDamagedRow(label_, "words", std::to_string(id),
                                 "holds a value that is not a finite number");
    created[i] = r.isNull(at, 1) ? -1 : r.integer(at, 1);
    ++at;
  }
}

void PgMapStore::putLocationWordDescriptors(const LocationWordDescriptors& words) {
  auto scope = writeScope();
  const std::vector<std::uint8_t> bytes = words.encode();
  db_->send(
      "INSERT INTO location_word_descriptors (location_id, dim, words, checksum) "
      "VALUES ($1, $2, $3, $4) ON CONFLICT (location_id) DO UPDATE SET dim = excluded.dim, "
      "words = excluded.words, checksum = excluded.checksum",
      detail::PgParams()
          .add(words.location_id)
          .add(std::int64_t{words.dim})
          .addBytes(bytes.data(), bytes.size())
          .add(std::int64_t{detail::locationWordDescriptorsChecksum(words.location_id, words.dim,
                                                                    bytes.data(), bytes.size())}));
  markHeld(words.location_id, detail::kHeldWordDescriptors, true);
  scope.commit();
}

std::vector<LocationWordDescriptors> PgMapStore::locationWordDescriptors(
    const std::vector<std::int64_t>& location_ids) const {
  const auto r = db_->run(
      "SELECT location_id, dim, words, checksum FROM location_word_descriptors "
      "WHERE location_id = ANY($1)",
      detail::PgParams().addArray(location_ids));
  std::unordered_map<std::int64_t, int> row_of;
  for (int i = 0; i < r.rows(); ++i) row_of[r.integer(i, 0)] = i;
  std::vector<LocationWordDescriptors> out;
  for (std::int64_t id : location_ids) {
    const auto found = row_of.find(id);
    if (found == row_of.end()) continue;
    const int i = found->second;
    const std::int64_t dim = r.integer(i, 1);
    const auto [data, size] = r.bytes(i, 2);
    const std::string row = std::to_string(id);
    if (!sumMatches(r, i, 3, detail::locationWordDescriptorsChecksum(id, dim, data, size)))
      detail::refuseDamagedRow(label_, "location_word_descriptors", row, "fails its checksum");
    LocationWordDescriptors words;
    const std::string fault = detail::locationWordDescriptorsFault(id, dim, data, size, &words);
    if (!fault.empty()) detail::refuseDamagedRow(label_, "location_word_descriptors", row, fault);
    out.push_back(std::move(words));
  }
  return out;
}

std::int64_t PgMapStore::wordCount() const {
  return db_->run("SELECT count(*) FROM words").integer(0, 0);
}

std::optional<std::int64_t> PgMapStore::maxWordId() const {
  return db_->run("SELECT max(id) FROM words").optionalInteger(0, 0);
}

std::vector<std::int64_t> PgMapStore::importedWordIds() const {
  const auto r =
      db_->run("SELECT id FROM words WHERE vocabulary_import_id IS NOT NULL ORDER BY id");
  std::vector<std::int64_t> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back(r.integer(i, 0));
  return out;
}

// ---- Word references ----

void PgMapStore::insertWordRefs(std::int64_t location_id, const std::vector<WordRef>& refs) {
  auto scope = writeScope();
  if (refs.empty()) {  // the digest stays the one written with the rows there are
    fresh_locations_.erase(location_id);
    return scope.commit();
  }
  std::vector<std::int64_t> words;
  std::vector<double> x, y, size, angle, response;
  for (const WordRef& ref : refs) {
    words.push_back(ref.word_id);
    x.push_back(ref.x);
    y.push_back(ref.y);
    size.push_back(ref.size);
    angle.push_back(ref.angle);
    response.push_back(ref.response);
  }
  // The digest of the whole signature. The engine writes a new location's at once: no earlier row
  // to read back (a round trip); appending to another's reads them first.
  std::vector<WordRef> all;
  if (!fresh_locations_.erase(location_id)) {
    const auto earlier = db_->run(
        "SELECT word_id, x, y, size, angle, response FROM word_refs WHERE location_id = $1 "
        "ORDER BY ordinal",
        detail::PgParams().add(location_id));
    all = readRefs(earlier, 0, earlier.rows(), 0);
  }
  all.insert(all.end(), refs.begin(), refs.end());
  // Ordinals continue after the location's last one, in the order given.
  db_->send(
      "INSERT INTO word_refs (location_id, ordinal, word_id, x, y, size, angle, response) "
      "SELECT $1, (SELECT coalesce(max(ordinal) + 1, 0) FROM word_refs WHERE location_id = $1) "
      "+ t.n - 1, t.w, t.x, t.y, t.s, t.a, t.r FROM unnest($2::int8[], $3::float8[], "
      "$4::float8[], $5::float8[], $6::float8[], $7::float8[]) WITH ORDINALITY "
      "AS t(w, x, y, s, a, r, n)",
      detail::PgParams()
          .add(location_id)
          .addArray(words)
          .addArray(x)
          .addArray(y)
          .addArray(size)
          .addArray(angle)
          .addArray(response));
  db_->send(
      "UPDATE locations SET refs_digest = $2 WHERE id = $1",
      detail::PgParams().add(location_id).add(std::int64_t{detail::refsDigest(location_id, all)}));
  scope.commit();
}

void PgMapStore::replaceWordRefs(std::int64_t location_id, const std::vector<WordRef>& refs) {
  auto scope = writeScope();
  db_->send("DELETE FROM word_refs WHERE location_id = $1", detail::PgParams().add(location_id));
  fresh_locations_.insert(location_id);  // no earlier reference left
  if (refs.empty())
    db_->send(
        "UPDATE locations SET refs_digest = $2 WHERE id = $1",
        detail::PgParams().add(location_id).add(std::int64_t{detail::refsDigest(location_id, {})}));
  insertWordRefs(location_id, refs);
  scope.commit();
}

std::vector<WordRef> PgMapStore::loadWordRefs(std::int64_t location_id) const {
  return std::move(loadWordRefs(std::vector<std::int64_t>{location_id})[location_id]);
}

std::map<std::int64_t, std::vector<WordRef>> PgMapStore::loadWordRefs(
    const std::vector<std::int64_t>& location_ids) const {
  std::map<std::int64_t, std::vector<WordRef>> out;
  for (std::int64_t id : location_ids) out[id];
  const auto r = db_->run(
      "SELECT location_id, word_id, x, y, size, angle, response, ordinal FROM word_refs "
      "WHERE location_id = ANY($1) ORDER BY location_id, ordinal",
      detail::PgParams().addArray(location_ids));
  for (int i = 0; i < r.rows(); ++i) {
    const std::string fault =
        detail::refValueFault(r.real(i, 2), r.real(i, 3), r.real(i, 4), r.real(i, 5), r.real(i, 6));
    if (!fault.empty())
      detail::refuseDamagedRow(
          label_, "word_refs",
          "(" + std::to_string(r.integer(i, 0)) + ", " + std::to_string(r.integer(i, 7)) + ")",
          fault);
  }
  for (int start = 0; start < r.rows();) {
    int end = start;
    while (end < r.rows() && r.integer(end, 0) == r.integer(start, 0)) ++end;
    out[r.integer(start, 0)] = readRefs(r, start, end, 1);
    start = end;
  }
  requireRefsDigests(out);
  return out;
}

void PgMapStore::requireRefsDigests(
    const std::map<std::int64_t, std::vector<WordRef>>& refs) const {
  std::vector<std::int64_t> ids;
  for (const auto& entry : refs) ids.push_back(entry.first);
  const auto r = db_->run("SELECT id, refs_digest FROM locations WHERE id = ANY($1)",
                          detail::PgParams().addArray(ids));
  std::map<std::int64_t, std::optional<std::int64_t>> digests;
  for (int i = 0; i < r.rows(); ++i) digests[r.integer(i, 0)] = r.optionalInteger(i, 1);
  for (const auto& [id, rows] : refs) {
    const auto found = digests.find(id);
    if (found == digests.end()) {
      if (rows.empty()) continue;  // no location, no references: nothing was read
      detail::refuseDamagedRow(label_, "locations", std::to_string(id),
                               "is missing (its word_refs are read)");
    }
    if (found->second != std::int64_t{detail::refsDigest(id, rows)})
      detail::refuseDamagedRow(label_, "word_refs", "of location " + std::to_string(id),
                               "do not match the location's refs_digest (" +
                                   std::to_string(rows.size()) +
                                   " rows: a reference was deleted, added or changed)");
  }
}

std::map<std::int64_t, std::vector<std::int64_t>> PgMapStore::loadWordIds(
    const std::vector<std::int64_t>& location_ids) const {
  // The whole references are read, to check them against the location's digest.
  std::map<std::int64_t, std::vector<std::int64_t>> out;
  for (auto& [id, refs] : loadWordRefs(location_ids)) {
    auto& ids = out[id];
    for (const WordRef& ref : refs) ids.push_back(ref.word_id);
  }
  return out;
}

std::vector<std::int64_t> PgMapStore::wordsOfLocations(
    const std::vector<std::int64_t>& location_ids) const {
  const auto r = db_->run(
      "SELECT DISTINCT word_id FROM word_refs WHERE location_id = ANY($1) ORDER BY word_id",
      detail::PgParams().addArray(location_ids));
  std::vector<std::int64_t> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back(r.integer(i, 0));
  return out;
}

std::vector<std::int64_t> PgMapStore::locationsOfWord(std::int64_t word_id) const {
  const auto r =
      db_->run("SELECT DISTINCT location_id FROM word_refs WHERE word_id = $1 ORDER BY location_id",
               detail::PgParams().add(word_id));
  std::vector<std::int64_t> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back(r.integer(i, 0));
  return out;
}

// ---- Links ----

void PgMapStore::insertLink(std::int64_t a, std::int64_t b, LinkType type,
                            std::optional<double> score) {
  if (a == b) {
    throw StorageError(ErrorCode::kInvalidArgument,
                       "link of location " + std::to_string(a) + " to itself");
  }
  auto scope = writeScope();
  // Both ends count a new link (schema 15, locations.link_count); xmax is 0 on a row inserted.
  db_->send(
      "WITH k AS (INSERT INTO links (location_a, location_b, type, score) VALUES ($1, $2, $3, $4) "
      "ON CONFLICT (location_a, location_b, type) DO UPDATE SET score = excluded.score "
      "RETURNING (xmax = 0) AS inserted) "
      "UPDATE locations SET link_count = link_count + 1 WHERE id IN ($1, $2) AND "
      "(SELECT inserted FROM k)",
      detail::PgParams()
          .add(std::min(a, b))
          .add(std::max(a, b))
          .add(std::int64_t{static_cast<int>(type)})
          .add(score));
  scope.commit();
}

std::vector<LinkRecord> PgMapStore::links(std::int64_t location_id) const {
  const auto r = db_->run(
      "SELECT location_a, location_b, type, score FROM links WHERE location_a = $1 "
      "UNION ALL SELECT location_a, location_b, type, score FROM links WHERE location_b = $1 "
      "ORDER BY 1, 2, 3",
      detail::PgParams().add(location_id));
  std::vector<LinkRecord> out;
  for (int i = 0; i < r.rows(); ++i)
    out.push_back({r.integer(i, 0), r.integer(i, 1), static_cast<LinkType>(r.integer(i, 2)),
                   r.optionalReal(i, 3)});
  return out;
}

std::vector<LinkRecord> PgMapStore::linksOfType(LinkType type) const {
  const auto r = db_->run(
      "SELECT location_a, location_b, type, score FROM links WHERE type = $1 ORDER BY 1, 2",
      detail::PgParams().add(std::int64_t{static_cast<int>(type)}));
  std::vector<LinkRecord> out;
  for (int i = 0; i < r.rows(); ++i)
    out.push_back({r.integer(i, 0), r.integer(i, 1), type, r.optionalReal(i, 3)});
  return out;
}

std::int64_t PgMapStore::linkCount(LinkType type) const {
  return db_
      ->run("SELECT count(*) FROM links WHERE type = $1",
            detail::PgParams().add(static_cast<std::int64_t>(type)))
      .integer(0, 0);
}

std::int64_t PgMapStore::acceptedClosureCount(bool posed) const {
  return db_
      ->run(posed ? "SELECT count(*) FROM v_loop_closure_poses"
                  : "SELECT count(*) FROM hypotheses WHERE accepted = 1")
      .integer(0, 0);
}

std::vector<std::int64_t> PgMapStore::linkedInTier(std::int64_t location_id, Tier tier,
                                                   std::optional<LinkType> type) const {
  if (side_session_) return sideLinkedInTier(location_id, tier, type);
  const auto r = db_->run(
      "SELECT DISTINCT k.other FROM ("
      "  SELECT location_b AS other, type FROM links WHERE location_a = $1"
      "  UNION ALL SELECT location_a, type FROM links WHERE location_b = $1) k "
      "JOIN locations l ON l.id = k.other "
      "WHERE l.tier = $2 AND ($3::int8 IS NULL OR k.type = $3) ORDER BY k.other",
      detail::PgParams()
          .add(location_id)
          .add(std::int64_t{static_cast<int>(tier)})
          .add(type ? std::optional<std::int64_t>(static_cast<int>(*type)) : std::nullopt));
  std::vector<std::int64_t> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back(r.integer(i, 0));
  return out;
}

// ---- Hypotheses ----

void PgMapStore::insertHypothesis(const HypothesisRecord& h) {
  auto scope = writeScope();
  detail::PgParams p;
  p.add(h.frame_id)
      .add(h.best_location_id)
      .add(h.posterior)
      .add(h.loop_probability)
      .add(std::int64_t{h.accepted ? 1 : 0})
      .addText(h.rejected_reason.empty() ? std::nullopt
                                         : std::optional<std::string>(h.rejected_reason));
  const std::optional<ClosurePose>& pose = h.pose;
  for (double ClosurePose::*field :
       {&ClosurePose::qw, &ClosurePose::qx, &ClosurePose::qy, &ClosurePose::qz, &ClosurePose::tx,
        &ClosurePose::ty, &ClosurePose::tz})
    p.add(pose ? std::optional<double>((*pose).*field) : std::nullopt);
  p.add(pose ? std::optional<std::int64_t>(pose->inliers) : std::nullopt);
  db_->send(
      "INSERT INTO hypotheses (frame_id, best_location_id, posterior, loop_probability, "
      "accepted, rejected_reason, pose_qw, pose_qx, pose_qy, pose_qz, pose_tx, pose_ty, pose_tz, "
      "pose_inliers) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14)",
      p);
  scope.commit();
}

namespace {

std::optional<ClosurePose> poseColumns(const detail::PgResult& r, int row, int first) {
  if (r.isNull(row, first)) return std::nullopt;
  ClosurePose p;
  double* values[] = {&p.qw, &p.qx, &p.qy, &p.qz, &p.tx, &p.ty, &p.tz};
  for (int i = 0; i < 7; ++i) *values[i] = r.real(row, first + i);
  p.inliers = r.integer(row, first + 7);
  return p;
}

}  // namespace

std::optional<HypothesisRecord> PgMapStore::hypothesis(std::int64_t frame_id) const {
  const auto r = db_->run(
      "SELECT frame_id, best_location_id, posterior, loop_probability, accepted, "
      "rejected_reason, pose_qw, pose_qx, pose_qy, pose_qz, pose_tx, pose_ty, pose_tz, "
      "pose_inliers FROM hypotheses WHERE frame_id = $1",
      detail::PgParams().add(frame_id));
  if (r.rows() == 0) return std::nullopt;
  HypothesisRecord h;
  h.frame_id = r.integer(0, 0);
  h.best_location_id = r.optionalInteger(0, 1);
  h.posterior = r.real(0, 2);
  h.loop_probability = r.real(0, 3);
  h.accepted = r.integer(0, 4) != 0;
  h.rejected_reason = r.text(0, 5);
  h.pose = poseColumns(r, 0, 6);
  return h;
}

std::vector<ClosurePoseRecord> PgMapStore::closurePoses() const {
  const auto r = db_->run(
      "SELECT h.frame_id, f.location_id, h.best_location_id, h.pose_qw, h.pose_qx, h.pose_qy, "
      "h.pose_qz, h.pose_tx, h.pose_ty, h.pose_tz, h.pose_inliers "
      "FROM hypotheses h JOIN frames f ON f.id = h.frame_id "
      "WHERE h.accepted = 1 AND h.pose_qw IS NOT NULL AND f.location_id IS NOT NULL "
      "AND h.best_location_id IS NOT NULL ORDER BY h.frame_id");
  std::vector<ClosurePoseRecord> out;
  for (int i = 0; i < r.rows(); ++i) {
    ClosurePoseRecord c;
    c.frame_id = r.integer(i, 0);
    c.frame_location_id = r.integer(i, 1);
    c.hypothesis_location_id = r.integer(i, 2);
    c.pose = *poseColumns(r, i, 3);
    out.push_back(c);
  }
  return out;
}

}  // namespace placedb::storage
