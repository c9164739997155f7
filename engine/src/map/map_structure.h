#pragma once
// What a map's rows must agree on beyond each row, checked when the engine opens a map, before
// anything is written: row checksums find a changed row, locations.held and refs_digest
// (storage) a row deleted or added with a location; this finds what no single row says. The
// counters that number frames, locations, words and WM ages follow the last row of each (a
// lone writer hands out every id in order: a counter behind the rows would give an id twice, one
// ahead changes what the next frame decides); the locations in short-term and working memory are
// those the counters recorded after the last frame; and the filter's posterior names locations of
// working (or, just transferred, long-term) memory and sums to one.
// Each refusal is kMapRefused naming the table and row.
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "map/engine_state.h"
#include "memory/memory_tiers.h"
#include "placedb/storage/map_store.h"

namespace placedb {

struct StoredMemory {
  const EngineCounters& counters;
  const MemorySnapshot& tiers;   // every location with its tier
  std::int64_t last_wm_age = 0;  // the highest stored WM age (a location's id where none)
  const std::vector<std::pair<std::int64_t, double>>& posterior;
  std::optional<std::int64_t> next_word_id;  // the vocabulary's, when it has a state
};

// Runs every check above; the caller has already run store.checkStoredRows().
void checkStoredMemory(const storage::MapStore& store, const StoredMemory& memory);

// Which locations are in short-term (`stm`) and working memory (`wm`, ascending): what the
// counters record after every frame (EngineCounters::tiers_digest), positive.
std::int64_t tiersDigest(std::vector<std::int64_t> stm, const std::vector<std::int64_t>& wm);

}  // namespace placedb
