// MapStore: the links between locations and the loop-closure hypothesis of each frame.
#include <algorithm>

#include "database.h"
#include "placedb/storage/map_store.h"
#include "write_scope.h"

namespace placedb::storage {

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

}  // namespace placedb::storage
