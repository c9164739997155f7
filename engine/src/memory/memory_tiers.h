#pragma once
// Which tier every location is in: short-term memory (STM, the newest locations, never loop
// candidates), working memory (WM, the loop candidates) or long-term memory (LTM, database only),
// with the weights and ages that choose what moves between WM and LTM (SPEC sections 5 and 7).
//
// Policies fixed here:
// - Age is the order of entering STM/WM: push() stamps each new location with the next sequence
//   number, and retrieveToWm() stamps a location brought back from LTM again, as RTAB-Map orders
//   its WM by entry time. "Oldest first among equal weights" uses it, as does "the newest part of
//   WM": the max(immune_newest_count, floor(immune_newest_ratio x |WM|)) WM locations of largest
//   age. A retrieved location therefore stays while the camera is around it, instead of being the
//   first to go again the next frame (it is old by creation and light).
// - How many to transfer (plannedTransfers): the size trigger asks for |WM| - wm_max; the time
//   trigger assumes frame time grows with |WM| and asks for ceil(|WM| x (t - T_time) / t), at
//   least 1, at most max_transfers_per_frame (0 = no cap), never below time_floor locations; the
//   larger request wins. A caller that
//   prefers RTAB-Map's word balance (transfer until as many words left the vocabulary as this
//   frame created) walks transferCandidates() in order, counting with a FreedWordCounter
//   (filter/inverted_index.h), and stops on its own.
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "memory/location_table.h"
#include "placedb/map.h"  // Tier
#include "placedb/options.h"

namespace placedb {

using MemoryLocationId = std::int64_t;

using storage::toString;                  // "stm", "wm", "ltm"
Tier parseTier(const std::string& name);  // "stm", "wm", "ltm"; kInvalidArgument otherwise

// Defaults are Options' (stm_size, wm_max, t_time_ms, wm_immune_newest, wm_recent_ratio,
// max_retrieved).
struct MemorySettings {
  int stm_size = Options().stm_size;                     // RTAB-Map's Mem/STMSize
  std::int64_t wm_max = Options().wm_max;                // WM size bound; 0 = bounded by time only
  double time_limit_s = Options().t_time_ms / 1000.0;    // T_time; 0 = no time trigger
  int immune_newest_count = Options().wm_immune_newest;  // newest WM locations never transferred
  // ... or this share of WM (RTAB-Map's Mem/RecentWmRatio)
  double immune_newest_ratio = Options().wm_recent_ratio;
  int max_transfers_per_frame = 0;              // cap of the time trigger; 0 = none
  std::int64_t time_floor = Options().wm_min;   // the time trigger never takes WM below this
  int max_retrieved = Options().max_retrieved;  // RTAB-Map's Rtabmap/MaxRetrieved

  // kInvalidArgument naming each bad field and its valid range; accepts at least what
  // Options::validate() accepts (options_test).
  void validate() const;
};

struct LocationRecord {
  MemoryLocationId id = 0;
  Tier tier = Tier::kStm;
  std::int64_t weight = 0;
  std::int64_t age = 0;  // creation order
  bool operator==(const LocationRecord& o) const {
    return id == o.id && tier == o.tier && weight == o.weight && age == o.age;
  }
};

// Everything needed to rebuild the tiers exactly; STM order is the order of `stm`.
struct MemorySnapshot {
  std::vector<LocationRecord> locations;  // sorted by id
  std::vector<MemoryLocationId> stm;      // oldest first
  std::int64_t next_age = 0;
  bool operator==(const MemorySnapshot& o) const {
    return locations == o.locations && stm == o.stm && next_age == o.next_age;
  }
};

class MemoryTiers {
 public:
  explicit MemoryTiers(const MemorySettings& settings = {});  // validates

  // Starts a frame: forgets which locations were retrieved during the previous one.
  void beginFrame() { retrieved_this_frame_.clear(); }

  // Adds a new location at the young end of STM with weight 0. With `absorb`, that location
  // (STM or WM) is merged into the new one first: it disappears from every tier and the new one
  // takes its weight + 1 (paper 004's rehearsal). Returns the locations STM overflowed into WM,
  // oldest first, counted after the merge.
  std::vector<MemoryLocationId> push(MemoryLocationId id,
                                     std::optional<MemoryLocationId> absorb = std::nullopt);
  // Merges `absorbed` into `survivor` (both in STM or WM): survivor weight += absorbed + 1, and
  // absorbed disappears. Use when the older id is kept.
  void merge(MemoryLocationId survivor, MemoryLocationId absorbed);
  void addWeight(MemoryLocationId id, std::int64_t delta);  // not below 0

  // How many WM locations the triggers ask to move to LTM (see the header comment).
  std::size_t plannedTransfers(double frame_seconds) const;
  // WM locations in transfer order (lowest weight, then oldest), skipping `immune`, the locations
  // retrieved this frame and the newest part of WM; at most max_count.
  std::vector<MemoryLocationId> transferCandidates(std::size_t max_count,
                                                   const std::set<MemoryLocationId>& immune) const;
  // Moves these WM locations to LTM (kInvalidArgument if one is not in WM).
  void transferToLtm(const std::vector<MemoryLocationId>& ids);

  // Of the given LTM neighbours of the best hypothesis (caller's order, e.g. nearest first), those
  // really in LTM, without repeats, at most max_retrieved.
  std::vector<MemoryLocationId> retrievalCandidates(
      MemoryLocationId best_hypothesis, const std::vector<MemoryLocationId>& ltm_neighbours) const;
  // The same with an explicit cap instead of settings().max_retrieved.
  std::vector<MemoryLocationId> retrievalCandidates(
      MemoryLocationId best_hypothesis, const std::vector<MemoryLocationId>& ltm_neighbours,
      std::size_t max_retrieved) const;
  // Moves these LTM locations to WM with a new age and marks them retrieved this frame.
  void retrieveToWm(const std::vector<MemoryLocationId>& ids);

  // Registers a location already in LTM (a previous session's map) without a frame.
  void addToLtm(MemoryLocationId id, std::int64_t weight);

  bool contains(MemoryLocationId id) const { return records_.contains(id); }
  bool isIn(MemoryLocationId id, Tier tier) const {  // known, and in that tier
    const LocationRecord* r = records_.find(id);
    return r && r->tier == tier;
  }
  Tier tierOf(MemoryLocationId id) const;  // kInvalidArgument when unknown
  std::int64_t weightOf(MemoryLocationId id) const;
  std::int64_t ageOf(MemoryLocationId id) const;
  const std::deque<MemoryLocationId>& stm() const { return stm_; }
  const std::vector<MemoryLocationId>& wm() const { return wm_ids_; }  // sorted by id
  std::vector<MemoryLocationId> ltm() const;  // sorted by id; a pass over every location
  std::size_t wmSize() const { return wm_by_priority_.size(); }
  std::size_t ltmSize() const { return ltm_count_; }
  const std::set<MemoryLocationId>& retrievedThisFrame() const { return retrieved_this_frame_; }
  std::int64_t nextAge() const { return next_age_; }
  // Newest part of WM as defined above.
  std::set<MemoryLocationId> newestWm() const;
  std::size_t newestWmCount() const;

  // Empty when every location is in exactly one tier and every index agrees with the records;
  // otherwise a description of the first problem found.
  std::string checkInvariants() const;

  MemorySnapshot snapshot() const;
  void restore(const MemorySnapshot& snapshot);  // kInvalidArgument when inconsistent
  const MemorySettings& settings() const { return settings_; }

 private:
  using Priority = std::tuple<std::int64_t, std::int64_t, MemoryLocationId>;  // weight, age, id
  LocationRecord& recordOf(MemoryLocationId id);
  const LocationRecord& recordOf(MemoryLocationId id) const;
  void enterWm(LocationRecord& r);
  void leaveWm(const LocationRecord& r);
  void removeEverywhere(MemoryLocationId id);

  MemorySettings settings_;
  // Every location of the map: in RAM for good, so kept flat (location_table.h).
  LocationTable<LocationRecord> records_;
  std::deque<MemoryLocationId> stm_;                               // oldest first
  std::set<Priority> wm_by_priority_;                              // transfer order
  std::set<std::pair<std::int64_t, MemoryLocationId>> wm_by_age_;  // newest part
  std::size_t ltm_count_ = 0;                                      // records in LTM
  // The filter asks for WM by id every frame: kept sorted here, not sorted out of wm_by_age_.
  std::vector<MemoryLocationId> wm_ids_;
  std::set<MemoryLocationId> retrieved_this_frame_;
  std::int64_t next_age_ = 0;
};

}  // namespace placedb
