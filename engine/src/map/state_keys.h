#pragma once
// Every key the engine keeps in the map's engine_state table (key -> blob), in one place, so that
// a reader of the map (schema/SCHEMA.md, tests, tools) and the engine agree on them.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

#include "placedb/storage/records.h"

namespace placedb {

// Signature of the features the map was made with ("surf-64"): a map never mixes extractors.
inline constexpr const char* kMapExtractorKey = "map.extractor";
// Mode of the imported vocabulary, "fixed" or "seed"; absent without an import.
inline constexpr const char* kVocabularyModeKey = "vocabulary.mode";
// The engine's counters as JSON (EngineCounters).
inline constexpr const char* kCountersKey = "engine.counters";
// The vocabulary index's header (IndexState without its nodes, which live in kd_nodes).
inline constexpr const char* kVocabularyHeaderKey = "vocabulary.header";
// The place codes' coarse centres (memory/place_code.h), written with the map's first location.
inline constexpr const char* kPlaceCoderKey = "place_codes.centres";
// Prefix of the split-log chunks of schema-2 maps, read once to convert them.
inline constexpr const char* kVocabularySplitsPrefix = "vocabulary.splits.";

// "vocabulary.splits.000042": chunk `chunk` of a schema-2 split log.
inline std::string vocabularySplitsKey(std::size_t chunk) {
  char key[48];
  std::snprintf(key, sizeof key, "%s%06zu", kVocabularySplitsPrefix, chunk);
  return key;
}

// "keypoint_descriptors/<id>": a location's own keypoint descriptors (see encodeDescriptors); one
// of the rows a location holds, named by storage.
inline std::string keypointDescriptorsKey(std::int64_t location_id) {
  return storage::locationKeypointsKey(location_id);
}

// "latest_view/<id>": the view of the latest frame merged into a location (latest_view.h),
// replaced at each merge; storage deletes it with the location.
inline std::string latestViewKey(std::int64_t location_id) {
  return storage::locationLatestViewKey(location_id);
}

}  // namespace placedb
