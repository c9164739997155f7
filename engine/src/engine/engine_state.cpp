// Engine counters as readable JSON, the vocabulary index state as a header plus split chunks.
#include "engine/engine_state.h"

#include <fmt/format.h>

#include <cstring>
#include <nlohmann/json.hpp>

#include "placedb/error.h"

namespace placedb {
namespace {

constexpr const char* kCountersKey = "engine.counters";
constexpr const char* kVocabularyHeaderKey = "vocabulary.header";
constexpr std::size_t kSplitBytes = 1 + 4 + 2 + 4;

std::string chunkKey(std::size_t chunk) { return fmt::format("vocabulary.splits.{:06}", chunk); }

template <typename T>
void put(std::vector<std::uint8_t>& out, T value) {
  std::uint8_t bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));  // little-endian targets only, as the index state
  out.insert(out.end(), bytes, bytes + sizeof(T));
}

template <typename T>
T get(const std::uint8_t* at) {
  T value;
  std::memcpy(&value, at, sizeof(T));
  return value;
}

}  // namespace

void EngineCounters::save(storage::MapStore& store) const {
  nlohmann::json j = {{"next_frame_id", next_frame_id},  {"next_location_id", next_location_id},
                      {"feature_sum", feature_sum},      {"feature_frames", feature_frames},
                      {"last_location", last_location},  {"last_session", last_session},
                      {"previous_score", previous_score},
                      {"last_closure_location", last_closure_location},
                      {"last_closure_frame", last_closure_frame},
                      {"last_closure_session", last_closure_session}};
  store.putState(kCountersKey, j.dump());
}

bool EngineCounters::load(const storage::MapStore& store) {
  auto text = store.getStateText(kCountersKey);
  if (!text) return false;
  try {
    auto j = nlohmann::json::parse(*text);
    next_frame_id = j.at("next_frame_id").get<std::int64_t>();
    next_location_id = j.at("next_location_id").get<std::int64_t>();
    feature_sum = j.at("feature_sum").get<std::int64_t>();
    feature_frames = j.at("feature_frames").get<std::int64_t>();
    last_location = j.at("last_location").get<std::int64_t>();
    last_session = j.at("last_session").get<std::int64_t>();
    previous_score = j.at("previous_score").get<double>();
    // Absent from maps made before temporal consistency: no closure to continue from.
    last_closure_location = j.value("last_closure_location", std::int64_t{0});
    last_closure_frame = j.value("last_closure_frame", std::int64_t{0});
    last_closure_session = j.value("last_closure_session", std::int64_t{0});
  } catch (const nlohmann::json::exception& e) {
    throw Error(ErrorCode::kMapRefused, fmt::format("{}: engine state '{}' is damaged: {}",
                                                    store.path(), kCountersKey, e.what()));
  }
  return true;
}

void VocabularyStateWriter::save(storage::MapStore& store, const vocab::Vocabulary& vocabulary) {
  const std::vector<vocab::SplitRecord>& splits = vocabulary.splitLog();
  if (vocabulary.nextWordId() != saved_next_word_id_ || saved_splits_ == 0) {
    vocab::IndexState header;  // Vocabulary::state() without its split log
    header.dim = vocabulary.dim();
    header.kd_trees = vocabulary.options().kd_trees;
    header.leaf_size = vocabulary.options().leaf_size;
    header.seed = vocabulary.options().seed;
    header.next_word_id = vocabulary.nextWordId();
    store.putState(kVocabularyHeaderKey, header.serialize());
    saved_next_word_id_ = header.next_word_id;
  }
  if (splits.size() == saved_splits_ && saved_splits_ != 0) return;
  // Rewrite from the chunk holding the first unsaved split to the end.
  for (std::size_t chunk = saved_splits_ / kSplitsPerChunk; chunk * kSplitsPerChunk < splits.size();
       ++chunk) {
    std::size_t begin = chunk * kSplitsPerChunk;
    std::size_t end = std::min(splits.size(), begin + kSplitsPerChunk);
    std::vector<std::uint8_t> bytes;
    bytes.reserve((end - begin) * kSplitBytes);
    for (std::size_t i = begin; i < end; ++i) {
      const auto& s = splits[i];
      put(bytes, s.tree);
      put(bytes, s.node);
      put(bytes, s.dim);
      put(bytes, s.value);
    }
    store.putState(chunkKey(chunk), bytes);
  }
  saved_splits_ = splits.size();
}

std::optional<vocab::IndexState> VocabularyStateWriter::load(const storage::MapStore& store) {
  auto header = store.getState(kVocabularyHeaderKey);
  if (!header) return std::nullopt;
  vocab::IndexState state;
  try {
    state = vocab::IndexState::deserialize(*header);
  } catch (const Error& e) {
    throw Error(ErrorCode::kMapRefused, store.path() + ": " + e.what());
  }
  for (std::size_t chunk = 0;; ++chunk) {
    auto bytes = store.getState(chunkKey(chunk));
    if (!bytes) break;
    if (bytes->size() % kSplitBytes != 0 || bytes->size() > kSplitsPerChunk * kSplitBytes)
      throw Error(ErrorCode::kMapRefused,
                  fmt::format("{}: vocabulary state chunk {} is damaged", store.path(), chunk));
    for (std::size_t at = 0; at < bytes->size(); at += kSplitBytes) {
      const std::uint8_t* p = bytes->data() + at;
      vocab::SplitRecord s;
      s.tree = get<std::uint8_t>(p);
      s.node = get<std::uint32_t>(p + 1);
      s.dim = get<std::uint16_t>(p + 5);
      s.value = get<float>(p + 7);
      state.splits.push_back(s);
    }
  }
  saved_splits_ = state.splits.size();
  saved_next_word_id_ = state.next_word_id;
  return state;
}

}  // namespace placedb
