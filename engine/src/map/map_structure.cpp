#include "map/map_structure.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "map/state_keys.h"
#include "placedb/error.h"

namespace placedb {
namespace {

[[noreturn]] void refuse(const storage::MapStore& store, const std::string& what) {
  throw Error(ErrorCode::kMapRefused, fmt::format("{} damaged: {}; nothing was written "
                                                  "(placedb check lists every damaged row)",
                                                  store.path(), what));
}

// "behind" or "ahead of": a counter against the id that must follow the last row.
const char* side(std::int64_t counter, std::int64_t expected) {
  return counter < expected ? "behind" : "ahead of";
}

}  // namespace

std::int64_t tiersDigest(std::vector<std::int64_t> stm, const std::vector<std::int64_t>& wm) {
  std::sort(stm.begin(), stm.end());
  std::uint64_t hash = 14695981039346656037ull;  // FNV-1a 64
  const auto add = [&hash](std::int64_t value) {
    for (int i = 0; i < 8; ++i) {
      hash ^= static_cast<std::uint64_t>(value) >> (8 * i) & 0xff;
      hash *= 1099511628211ull;
    }
  };
  for (std::int64_t id : stm) add(id);
  add(-1);  // between the tiers
  for (std::int64_t id : wm) add(id);
  return static_cast<std::int64_t>(hash >> 1) | 1;  // positive, never 0 (0: none recorded)
}

void checkStoredMemory(const storage::MapStore& store, const StoredMemory& memory) {
  const EngineCounters& c = memory.counters;
  std::int64_t stm = 0, wm = 0, last_location = 0;
  const std::int64_t last_age = memory.last_wm_age;
  std::map<std::int64_t, Tier> tiers;
  std::vector<std::int64_t> stm_ids, wm_ids;
  for (const LocationRecord& l : memory.tiers.locations) {
    if (l.tier == Tier::kStm) stm_ids.push_back(l.id);
    if (l.tier == Tier::kWm) wm_ids.push_back(l.id);
    tiers[l.id] = l.tier;
    stm += l.tier == Tier::kStm;
    wm += l.tier == Tier::kWm;
    last_location = std::max(last_location, l.id);
  }
  // Other writers of a server map hand out ids from blocks of their own, and number their
  // frames past this one's: only a lone writer's counters follow the rows.
  const bool lone = !store.sharedByWriters() && c.frame_block_end == 0 &&
                    c.location_block_end == 0 && c.word_block_end == 0;
  if (lone) {
    const auto last = store.lastFrame();
    const std::int64_t next_frame = last ? last->id + 1 : 1;
    if (c.next_frame_id != next_frame)
      refuse(store, fmt::format("engine_state row '{}' holds next_frame_id = {}, {} the frames "
                                "rows (the last is {}, so it must be {})",
                                kCountersKey, c.next_frame_id, side(c.next_frame_id, next_frame),
                                last ? std::to_string(last->id) : "none", next_frame));
    if (c.next_location_id != last_location + 1)
      refuse(store, fmt::format("engine_state row '{}' holds next_location_id = {}, {} the "
                                "locations rows (the last is {}, so it must be {})",
                                kCountersKey, c.next_location_id,
                                side(c.next_location_id, last_location + 1), last_location,
                                last_location + 1));
    if (!memory.tiers.locations.empty() && c.next_wm_age != last_age + 1)
      refuse(store, fmt::format("engine_state row '{}' holds next_wm_age = {}, {} the wm_entries "
                                "rows (the last age is {}, so it must be {})",
                                kCountersKey, c.next_wm_age, side(c.next_wm_age, last_age + 1),
                                last_age, last_age + 1));
    // Imported words keep the ids of their file, and the vocabulary grows past them.
    if (memory.next_word_id) {
      const std::int64_t last_word = store.maxWordId().value_or(-1);
      const bool imported = !store.importedWordIds().empty();
      if (*memory.next_word_id <= last_word || (!imported && *memory.next_word_id != last_word + 1))
        refuse(store, fmt::format("engine_state row '{}' holds next_word_id = {}, {} the words "
                                  "rows (the last is {})",
                                  kVocabularyHeaderKey, *memory.next_word_id,
                                  side(*memory.next_word_id, last_word + 1), last_word));
    }
  }
  // Which locations are in short-term and working memory, as the last frame left them.
  if (c.tiers_digest != 0 && c.tiers_digest != tiersDigest(stm_ids, wm_ids))
    refuse(store, fmt::format("locations rows put {} locations in short-term and {} in working "
                              "memory, not those engine_state row '{}' recorded "
                              "(tiers_digest): tiers were changed",
                              stm, wm, kCountersKey));
  // The posterior is the filter's over working memory (and the virtual new place, ids <= 0): a
  // location it holds may have left for long-term memory after the filter ran, and one that
  // entered working memory after it (from short-term memory) has no row until the next frame.
  double sum = 0;
  for (const auto& [location, p] : memory.posterior) {
    sum += p;
    if (location <= 0) continue;
    const auto it = tiers.find(location);
    if (it == tiers.end() || it->second == Tier::kStm)
      refuse(store,
             fmt::format("filter_posterior row {} names {}", location,
                         it == tiers.end() ? "no location" : "a location in short-term memory"));
  }
  if (memory.posterior.empty() && wm > 0)
    refuse(store, fmt::format("filter_posterior holds no row, where {} locations are in working "
                              "memory (rows were deleted)",
                              wm));
  if (!memory.posterior.empty() && std::abs(sum - 1) > 1e-6)
    refuse(store, fmt::format("filter_posterior rows sum to {}, not 1 (rows were deleted, added "
                              "or changed)",
                              sum));
}

}  // namespace placedb
