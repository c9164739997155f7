#include "memory/memory_tiers.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "placedb/error.h"

namespace placedb {

namespace {
[[noreturn]] void invalid(const std::string& message) {
  throw Error(ErrorCode::kInvalidArgument, "memory tiers: " + message);
}
std::string idText(MemoryLocationId id) { return std::to_string(id); }
}  // namespace

Tier parseTier(const std::string& name) {
  if (name == "stm") return Tier::kStm;
  if (name == "wm") return Tier::kWm;
  if (name == "ltm") return Tier::kLtm;
  invalid("unknown tier '" + name + "'; valid: stm, wm, ltm");
}

void MemorySettings::validate() const {
  std::ostringstream problems;
  if (stm_size < 0 || stm_size > 100000) problems << " stm_size=" << stm_size << " (0..100000);";
  if (wm_max < 0) problems << " wm_max=" << wm_max << " (>= 0, 0 = unbounded);";
  if (!(time_limit_s >= 0.0) || !std::isfinite(time_limit_s)) {
    problems << " time_limit_s=" << time_limit_s << " (finite, >= 0, 0 = off);";
  }
  if (immune_newest_count < 0) {
    problems << " immune_newest_count=" << immune_newest_count << " (>= 0);";
  }
  if (!(immune_newest_ratio >= 0.0 && immune_newest_ratio < 1.0)) {
    problems << " immune_newest_ratio=" << immune_newest_ratio << " (0 <= x < 1);";
  }
  if (max_transfers_per_frame < 0) {
    problems << " max_transfers_per_frame=" << max_transfers_per_frame << " (>= 0, 0 = no cap);";
  }
  if (max_retrieved < 0) problems << " max_retrieved=" << max_retrieved << " (>= 0);";
  if (time_floor < 0) problems << " time_floor=" << time_floor << " (>= 0);";
  const std::string text = problems.str();
  if (!text.empty()) throw Error(ErrorCode::kInvalidArgument, "invalid memory settings:" + text);
}

MemoryTiers::MemoryTiers(const MemorySettings& settings) : settings_(settings) {
  settings_.validate();
}

LocationRecord& MemoryTiers::recordOf(MemoryLocationId id) {
  LocationRecord* r = records_.find(id);
  if (!r) invalid("unknown location " + idText(id));
  return *r;
}

const LocationRecord& MemoryTiers::recordOf(MemoryLocationId id) const {
  const LocationRecord* r = records_.find(id);
  if (!r) invalid("unknown location " + idText(id));
  return *r;
}

void MemoryTiers::enterWm(LocationRecord& r) {
  r.tier = Tier::kWm;
  wm_by_priority_.emplace(r.weight, r.age, r.id);
  wm_by_age_.emplace(r.age, r.id);
  wm_ids_.insert(std::lower_bound(wm_ids_.begin(), wm_ids_.end(), r.id), r.id);
}

void MemoryTiers::leaveWm(const LocationRecord& r) {
  wm_by_priority_.erase(Priority{r.weight, r.age, r.id});
  wm_by_age_.erase({r.age, r.id});
  const auto at = std::lower_bound(wm_ids_.begin(), wm_ids_.end(), r.id);
  if (at != wm_ids_.end() && *at == r.id) wm_ids_.erase(at);
}

void MemoryTiers::removeEverywhere(MemoryLocationId id) {
  const LocationRecord& r = recordOf(id);
  switch (r.tier) {
    case Tier::kStm:
      stm_.erase(std::find(stm_.begin(), stm_.end(), id));
      break;
    case Tier::kWm:
      leaveWm(r);
      break;
    case Tier::kLtm:
      --ltm_count_;
      break;
  }
  retrieved_this_frame_.erase(id);
  records_.erase(id);
}

std::vector<MemoryLocationId> MemoryTiers::push(MemoryLocationId id,
                                                std::optional<MemoryLocationId> absorb) {
  if (contains(id)) invalid("location " + idText(id) + " pushed twice");
  std::int64_t weight = 0;
  if (absorb) {
    const LocationRecord& old = recordOf(*absorb);
    if (old.tier == Tier::kLtm) invalid("cannot merge LTM location " + idText(*absorb));
    weight = old.weight + 1;
    removeEverywhere(*absorb);
  }
  records_.insert(id, LocationRecord{id, Tier::kStm, weight, next_age_++});
  stm_.push_back(id);
  std::vector<MemoryLocationId> overflow;
  while (stm_.size() > static_cast<std::size_t>(settings_.stm_size)) {
    const MemoryLocationId oldest = stm_.front();
    stm_.pop_front();
    enterWm(recordOf(oldest));
    overflow.push_back(oldest);
  }
  return overflow;
}

void MemoryTiers::merge(MemoryLocationId survivor, MemoryLocationId absorbed) {
  if (survivor == absorbed) invalid("location " + idText(survivor) + " merged into itself");
  const LocationRecord& gone = recordOf(absorbed);
  const LocationRecord& kept = recordOf(survivor);
  if (gone.tier == Tier::kLtm || kept.tier == Tier::kLtm) {
    invalid("merge of " + idText(absorbed) + " into " + idText(survivor) + " involves LTM");
  }
  const std::int64_t gained = gone.weight + 1;
  removeEverywhere(absorbed);
  addWeight(survivor, gained);
}

void MemoryTiers::addWeight(MemoryLocationId id, std::int64_t delta) {
  LocationRecord& r = recordOf(id);
  const bool in_wm = r.tier == Tier::kWm;
  if (in_wm) leaveWm(r);
  r.weight = std::max<std::int64_t>(0, r.weight + delta);
  if (in_wm) enterWm(r);
}

std::size_t MemoryTiers::plannedTransfers(double frame_seconds) const {
  const std::size_t wm_size = wmSize();
  std::size_t by_size = 0;
  if (settings_.wm_max > 0 && wm_size > static_cast<std::size_t>(settings_.wm_max)) {
    by_size = wm_size - static_cast<std::size_t>(settings_.wm_max);
  }
  std::size_t by_time = 0;
  if (settings_.time_limit_s > 0.0 && frame_seconds > settings_.time_limit_s && wm_size > 0) {
    const double excess = (frame_seconds - settings_.time_limit_s) / frame_seconds;
    by_time = static_cast<std::size_t>(std::ceil(static_cast<double>(wm_size) * excess));
    by_time = std::max<std::size_t>(by_time, 1);
    if (settings_.max_transfers_per_frame > 0) {
      by_time = std::min(by_time, static_cast<std::size_t>(settings_.max_transfers_per_frame));
    }
    const auto floor = static_cast<std::size_t>(std::max<std::int64_t>(settings_.time_floor, 0));
    by_time = wm_size > floor ? std::min(by_time, wm_size - floor) : 0;
  }
  return std::min(std::max(by_size, by_time), wm_size);
}

std::size_t MemoryTiers::newestWmCount() const {
  const auto by_ratio = static_cast<std::size_t>(
      std::floor(settings_.immune_newest_ratio * static_cast<double>(wmSize())));
  return std::min(wmSize(),
                  std::max(by_ratio, static_cast<std::size_t>(settings_.immune_newest_count)));
}

std::set<MemoryLocationId> MemoryTiers::newestWm() const {
  std::set<MemoryLocationId> newest;
  std::size_t left = newestWmCount();
  for (auto it = wm_by_age_.rbegin(); it != wm_by_age_.rend() && left > 0; ++it, --left) {
    newest.insert(it->second);
  }
  return newest;
}

std::vector<MemoryLocationId> MemoryTiers::transferCandidates(
    std::size_t max_count, const std::set<MemoryLocationId>& immune) const {
  const std::set<MemoryLocationId> newest = newestWm();
  std::vector<MemoryLocationId> chosen;
  for (const auto& [weight, age, id] : wm_by_priority_) {
    if (chosen.size() >= max_count) break;
    if (immune.count(id) || retrieved_this_frame_.count(id) || newest.count(id)) continue;
    chosen.push_back(id);
  }
  return chosen;
}

void MemoryTiers::transferToLtm(const std::vector<MemoryLocationId>& ids) {
  // Checked in full first, so a refused call changes nothing.
  std::set<MemoryLocationId> distinct;
  for (MemoryLocationId id : ids) {
    if (tierOf(id) != Tier::kWm) invalid("transfer of " + idText(id) + ", which is not in WM");
    if (!distinct.insert(id).second) invalid("location " + idText(id) + " transferred twice");
  }
  for (MemoryLocationId id : ids) {
    LocationRecord& r = recordOf(id);
    leaveWm(r);
    r.tier = Tier::kLtm;
    ++ltm_count_;
    retrieved_this_frame_.erase(id);
  }
}

std::vector<MemoryLocationId> MemoryTiers::retrievalCandidates(
    MemoryLocationId best_hypothesis, const std::vector<MemoryLocationId>& ltm_neighbours) const {
  return retrievalCandidates(best_hypothesis, ltm_neighbours,
                             static_cast<std::size_t>(settings_.max_retrieved));
}

std::vector<MemoryLocationId> MemoryTiers::retrievalCandidates(
    MemoryLocationId best_hypothesis, const std::vector<MemoryLocationId>& ltm_neighbours,
    std::size_t max_retrieved) const {
  std::vector<MemoryLocationId> chosen;
  if (best_hypothesis < 0) return chosen;  // no hypothesis, nothing to bring back
  for (MemoryLocationId id : ltm_neighbours) {
    if (chosen.size() >= max_retrieved) break;
    if (!isIn(id, Tier::kLtm)) continue;
    if (std::find(chosen.begin(), chosen.end(), id) != chosen.end()) continue;
    chosen.push_back(id);
  }
  return chosen;
}

void MemoryTiers::retrieveToWm(const std::vector<MemoryLocationId>& ids) {
  std::set<MemoryLocationId> distinct;
  for (MemoryLocationId id : ids) {
    if (tierOf(id) != Tier::kLtm) invalid("retrieval of " + idText(id) + ", which is not in LTM");
    if (!distinct.insert(id).second) invalid("location " + idText(id) + " retrieved twice");
  }
  for (MemoryLocationId id : ids) {
    LocationRecord& r = recordOf(id);
    --ltm_count_;
    r.age = next_age_++;  // new to WM: the place the camera just came back to goes last
    enterWm(r);
    retrieved_this_frame_.insert(id);
  }
}

void MemoryTiers::addToLtm(MemoryLocationId id, std::int64_t weight) {
  if (contains(id)) invalid("location " + idText(id) + " added twice");
  if (weight < 0) invalid("negative weight for location " + idText(id));
  records_.insert(id, LocationRecord{id, Tier::kLtm, weight, next_age_++});
  ++ltm_count_;
}

Tier MemoryTiers::tierOf(MemoryLocationId id) const { return recordOf(id).tier; }
std::int64_t MemoryTiers::weightOf(MemoryLocationId id) const { return recordOf(id).weight; }
std::int64_t MemoryTiers::ageOf(MemoryLocationId id) const { return recordOf(id).age; }

std::vector<MemoryLocationId> MemoryTiers::ltm() const {
  std::vector<MemoryLocationId> ids;
  ids.reserve(ltm_count_);
  records_.forEach([&](MemoryLocationId id, const LocationRecord& r) {
    if (r.tier == Tier::kLtm) ids.push_back(id);
  });
  return ids;
}

std::string MemoryTiers::checkInvariants() const {
  std::ostringstream problem;
  std::map<MemoryLocationId, int> seen;  // how many tier indexes list each id
  std::set<MemoryLocationId> stm_ids;
  for (MemoryLocationId id : stm_) {
    ++seen[id];
    if (!stm_ids.insert(id).second) return "location " + idText(id) + " twice in STM";
  }
  if (wm_by_priority_.size() != wm_by_age_.size() || wm_ids_.size() != wm_by_age_.size())
    return "WM indexes differ in size";
  if (!std::is_sorted(wm_ids_.begin(), wm_ids_.end())) return "WM ids out of order";
  for (const auto& [weight, age, id] : wm_by_priority_) {
    ++seen[id];
    if (wm_by_age_.count({age, id}) == 0) return "WM location " + idText(id) + " lacks its age";
    if (!std::binary_search(wm_ids_.begin(), wm_ids_.end(), id))
      return "WM location " + idText(id) + " lacks its id";
    const LocationRecord* rec = records_.find(id);
    if (!rec || rec->weight != weight || rec->age != age) {
      return "WM location " + idText(id) + " indexed with a stale weight or age";
    }
  }
  std::size_t in_ltm = 0;
  records_.forEach([&](MemoryLocationId id, const LocationRecord& r) {
    if (r.tier != Tier::kLtm) return;
    ++seen[id];
    ++in_ltm;
  });
  if (in_ltm != ltm_count_)
    return "LTM counted " + std::to_string(ltm_count_) + ", not " + std::to_string(in_ltm);
  if (stm_.size() > static_cast<std::size_t>(settings_.stm_size)) return "STM over its size";
  for (const auto& [id, count] : seen) {
    if (count != 1) return "location " + idText(id) + " is in " + std::to_string(count) + " tiers";
    if (!records_.contains(id)) return "location " + idText(id) + " in a tier but unknown";
  }
  std::string wrong;
  records_.forEach([&](MemoryLocationId id, const LocationRecord& r) {
    if (!wrong.empty()) return;
    if (r.id != id)
      wrong = "record of " + idText(id) + " names " + idText(r.id);
    else if (seen.count(id) == 0)
      wrong = "location " + idText(id) + " is in no tier";
    else if (!((r.tier == Tier::kStm && stm_ids.count(id)) ||
               (r.tier == Tier::kWm && wm_by_age_.count({r.age, id})) || r.tier == Tier::kLtm))
      wrong = "location " + idText(id) + " is not where its record says";
    else if (r.weight < 0)
      wrong = "location " + idText(id) + " has a negative weight";
    else if (r.age >= next_age_)
      wrong = "location " + idText(id) + " is younger than the clock";
  });
  if (!wrong.empty()) return wrong;
  for (MemoryLocationId id : retrieved_this_frame_) {
    const LocationRecord* rec = records_.find(id);
    if (!rec || rec->tier != Tier::kWm) {
      return "retrieved location " + idText(id) + " is not in WM";
    }
  }
  return problem.str();
}

MemorySnapshot MemoryTiers::snapshot() const {
  MemorySnapshot s;
  s.locations.reserve(records_.size());
  records_.forEach([&](MemoryLocationId, const LocationRecord& r) { s.locations.push_back(r); });
  s.stm.assign(stm_.begin(), stm_.end());
  s.next_age = next_age_;
  return s;
}

void MemoryTiers::restore(const MemorySnapshot& snapshot) {
  MemoryTiers rebuilt(settings_);
  for (const LocationRecord& r : snapshot.locations) {
    if (rebuilt.records_.contains(r.id)) invalid("snapshot lists " + idText(r.id) + " twice");
    LocationRecord& added = rebuilt.records_.insert(r.id, r);
    if (r.tier == Tier::kWm) rebuilt.enterWm(added);
    if (r.tier == Tier::kLtm) ++rebuilt.ltm_count_;
  }
  for (MemoryLocationId id : snapshot.stm) {
    const LocationRecord* r = rebuilt.records_.find(id);
    if (!r || r->tier != Tier::kStm) {
      invalid("snapshot STM lists " + idText(id) + ", which is not an STM record");
    }
    rebuilt.stm_.push_back(id);
  }
  rebuilt.next_age_ = snapshot.next_age;
  const std::string problem = rebuilt.checkInvariants();
  if (!problem.empty()) invalid("inconsistent snapshot: " + problem);
  *this = std::move(rebuilt);
}

}  // namespace placedb
