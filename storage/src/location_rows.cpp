#include "location_rows.h"

#include <string>

#include "placedb/storage/records.h"
#include "row_checksums.h"

namespace placedb::storage::detail {
namespace {

std::string keypointsKeyPrefix() { return kLocationKeypointsKeyPrefix; }

}  // namespace

std::string heldRowProblem(std::int64_t location_id, bool held, bool present) {
  const std::string id = std::to_string(location_id);
  if (held && !present) return "is missing: location " + id + " holds one (locations.held)";
  if (!held && present)
    return "is there, but location " + id + " holds none (locations.held): it was added";
  return "";
}

const std::string& locationRowFactsQuery() {
  static const std::string sql =
      "SELECT l.id, l.tier, l.held, l.refs_digest IS NOT NULL, p.location_id IS NOT NULL, "
      "EXISTS (SELECT 1 FROM location_word_descriptors d WHERE d.location_id = l.id), "
      "EXISTS (SELECT 1 FROM engine_state s WHERE s.key = '" +
      keypointsKeyPrefix() +
      "' || l.id), "
      "w.location_id IS NOT NULL, w.wm_age, w.checksum, l.session_id, l.weight, l.created_frame, "
      "l.checksum FROM locations l LEFT JOIN place_codes p ON p.location_id = l.id "
      "LEFT JOIN wm_entries w ON w.location_id = l.id";
  return sql;
}

void judgeLocationRow(const LocationRowFacts& f, const FindingSink& found) {
  const std::string row = std::to_string(f.id);
  if (!f.checksum ||
      *f.checksum != std::int64_t{locationChecksum(f.id, f.session_id, f.weight, f.created_frame)})
    found({"locations", row, "fails its checksum"});
  if (!f.tier || *f.tier < 0 || *f.tier > 2)
    found({"locations", row,
           "has tier " + (f.tier ? std::to_string(*f.tier) : std::string("NULL")) +
               " (0 STM, 1 WM, 2 LTM)"});
  if (!f.held || !f.has_digest) {
    found({"locations", row, "records none of its rows (held or refs_digest is NULL)"});
    return;
  }
  const struct {
    std::int64_t bit;
    const char* table;
    bool present;
  } parts[] = {{kHeldPlaceCode, "place_codes", f.place_code},
               {kHeldWordDescriptors, "location_word_descriptors", f.word_descriptors},
               {kHeldKeypoints, "engine_state", f.keypoints},
               {kHeldWmEntry, "wm_entries", f.wm_entry}};
  for (const auto& part : parts) {
    const std::string problem = heldRowProblem(f.id, (*f.held & part.bit) != 0, part.present);
    if (!problem.empty())
      found({part.table, part.bit == kHeldKeypoints ? "'" + locationKeypointsKey(f.id) + "'" : row,
             problem});
  }
  if (f.wm_entry) {
    if (!f.wm_checksum || *f.wm_checksum != std::int64_t{wmEntryChecksum(f.id, f.wm_age)})
      found({"wm_entries", row, "fails its checksum"});
    else if (f.wm_age < 1)
      found({"wm_entries", row, "holds a WM age below 1"});
  }
}

const std::string& linkCountQuery() {
  static const std::string sql =
      "SELECT id, link_count, (SELECT count(*) FROM links k WHERE k.location_a = l.id) + "
      "(SELECT count(*) FROM links k WHERE k.location_b = l.id) FROM locations l";
  return sql;
}

std::string linkCountProblem(std::optional<std::int64_t> recorded, std::int64_t counted) {
  if (recorded == counted) return "";
  return "hold " + std::to_string(counted) + " rows where the location records " +
         (recorded ? std::to_string(*recorded) : std::string("none")) +
         " (a link was deleted or added)";
}

}  // namespace placedb::storage::detail
