// MapStore: the links between locations and the loop-closure hypothesis of each frame.
#include <algorithm>

#include "placedb/storage/sqlite_map_store.h"
#include "sqlite/database.h"

namespace placedb::storage {

// ---- Links ----

void SqliteMapStore::insertLink(std::int64_t a, std::int64_t b, LinkType type,
                                std::optional<double> score) {
  if (a == b) {
    throw StorageError(ErrorCode::kInvalidArgument,
                       "link of location " + std::to_string(a) + " to itself");
  }
  auto scope = writeScope();
  bool known = false;
  {
    auto s =
        db_->cached("SELECT 1 FROM links WHERE location_a = ?1 AND location_b = ?2 AND type = ?3");
    s->bind(1, std::min(a, b));
    s->bind(2, std::max(a, b));
    s->bind(3, std::int64_t{static_cast<int>(type)});
    known = s->step();
  }
  auto s = db_->cached(
      "INSERT INTO links (location_a, location_b, type, score) VALUES (?1, ?2, ?3, ?4) "
      "ON CONFLICT (location_a, location_b, type) DO UPDATE SET score = excluded.score");
  s->bind(1, std::min(a, b));
  s->bind(2, std::max(a, b));
  s->bind(3, std::int64_t{static_cast<int>(type)});
  s->bind(4, score);
  s->run();
  if (!known) {  // both ends count it (schema 15, locations.link_count)
    auto count =
        db_->cached("UPDATE locations SET link_count = link_count + 1 WHERE id IN (?1, ?2)");
    count->bind(1, a);
    count->bind(2, b);
    count->run();
  }
  scope.commit();
}

std::vector<LinkRecord> SqliteMapStore::links(std::int64_t location_id) const {
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

std::vector<LinkRecord> SqliteMapStore::linksOfType(LinkType type) const {
  auto s = db_->cached(
      "SELECT location_a, location_b, type, score FROM links WHERE type = ?1 ORDER BY 1, 2");
  s->bind(1, std::int64_t{static_cast<int>(type)});
  std::vector<LinkRecord> result;
  while (s->step())
    result.push_back({s->columnInt(0), s->columnInt(1), type, s->columnOptionalDouble(3)});
  return result;
}

std::vector<std::int64_t> SqliteMapStore::linkedInTier(std::int64_t location_id, Tier tier,
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

void SqliteMapStore::insertHypothesis(const HypothesisRecord& h) {
  auto scope = writeScope();
  auto s = db_->cached(
      "INSERT INTO hypotheses (frame_id, best_location_id, posterior, loop_probability, "
      "accepted, rejected_reason, pose_qw, pose_qx, pose_qy, pose_qz, pose_tx, pose_ty, pose_tz, "
      "pose_inliers) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14)");
  s->bind(1, h.frame_id);
  s->bind(2, h.best_location_id);
  s->bind(3, h.posterior);
  s->bind(4, h.loop_probability);
  s->bind(5, std::int64_t{h.accepted ? 1 : 0});
  if (!h.rejected_reason.empty()) s->bind(6, h.rejected_reason);
  if (h.pose) {
    const ClosurePose& p = *h.pose;
    int column = 7;
    for (double v : {p.qw, p.qx, p.qy, p.qz, p.tx, p.ty, p.tz}) s->bind(column++, v);
    s->bind(column, p.inliers);
  }
  s->run();
  scope.commit();
}

namespace {

// Columns first..first+7 of a row: the pose_* columns in table order; none when NULL.
std::optional<ClosurePose> poseColumns(const detail::Statement& s, int first) {
  if (!s.columnOptionalDouble(first)) return std::nullopt;
  ClosurePose p;
  double* values[] = {&p.qw, &p.qx, &p.qy, &p.qz, &p.tx, &p.ty, &p.tz};
  for (int i = 0; i < 7; ++i) *values[i] = s.columnDouble(first + i);
  p.inliers = s.columnInt(first + 7);
  return p;
}

}  // namespace

std::optional<HypothesisRecord> SqliteMapStore::hypothesis(std::int64_t frame_id) const {
  auto s = db_->cached(
      "SELECT frame_id, best_location_id, posterior, loop_probability, accepted, "
      "rejected_reason, pose_qw, pose_qx, pose_qy, pose_qz, pose_tx, pose_ty, pose_tz, "
      "pose_inliers FROM hypotheses WHERE frame_id = ?1");
  s->bind(1, frame_id);
  if (!s->step()) return std::nullopt;
  HypothesisRecord h;
  h.frame_id = s->columnInt(0);
  h.best_location_id = s->columnOptionalInt(1);
  h.posterior = s->columnDouble(2);
  h.loop_probability = s->columnDouble(3);
  h.accepted = s->columnInt(4) != 0;
  h.rejected_reason = s->columnText(5);
  h.pose = poseColumns(*s, 6);
  return h;
}

std::vector<ClosurePoseRecord> SqliteMapStore::closurePoses() const {
  auto s = db_->cached(
      "SELECT h.frame_id, f.location_id, h.best_location_id, h.pose_qw, h.pose_qx, h.pose_qy, "
      "h.pose_qz, h.pose_tx, h.pose_ty, h.pose_tz, h.pose_inliers "
      "FROM hypotheses h JOIN frames f ON f.id = h.frame_id "
      "WHERE h.accepted = 1 AND h.pose_qw IS NOT NULL AND f.location_id IS NOT NULL "
      "AND h.best_location_id IS NOT NULL ORDER BY h.frame_id");
  std::vector<ClosurePoseRecord> out;
  while (s->step()) {
    ClosurePoseRecord r;
    r.frame_id = s->columnInt(0);
    r.frame_location_id = s->columnInt(1);
    r.hypothesis_location_id = s->columnInt(2);
    r.pose = *poseColumns(*s, 3);
    out.push_back(r);
  }
  return out;
}

}  // namespace placedb::storage
