// Engine counters as readable JSON; the vocabulary index state as a header plus the kd_nodes rows.
#include "map/engine_state.h"

#include <cmath>

#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "map/state_keys.h"
#include "placedb/error.h"

namespace placedb {
namespace {

constexpr std::size_t kSplitBytes = 1 + 4 + 2 + 4;  // a split-log record

}  // namespace

void EngineCounters::save(storage::MapStore& store) const {
  nlohmann::json j = {{"next_frame_id", next_frame_id},
                      {"next_location_id", next_location_id},
                      {"feature_sum", feature_sum},
                      {"feature_frames", feature_frames},
                      {"last_location", last_location},
                      {"last_session", last_session},
                      {"previous_score", previous_score},
                      {"last_closure_location", closure_run.anchor},
                      {"last_closure_frame", closure_run.frame},
                      {"last_closure_session", closure_run.session},
                      {"closure_run_first", closure_run.first},
                      {"closure_run_heading", closure_run.heading},
                      {"evidence_location", closure_evidence.location},
                      {"evidence_frame", closure_evidence.frame},
                      {"evidence_session", closure_evidence.session},
                      {"evidence_log10_nfa", closure_evidence.log10_nfa},
                      {"evidence_log10_product", closure_evidence.log10_product},
                      {"evidence_log10_alternatives", closure_evidence.log10_alternatives},
                      {"evidence_frames", closure_evidence.frames},
                      {"next_wm_age", next_wm_age}};
  if (tiers_digest != 0) j["tiers_digest"] = tiers_digest;
  if (refuted.location != 0) {
    j["refuted_location"] = refuted.location;
    j["refuted_frame"] = refuted.frame;
    j["refuted_session"] = refuted.session;
    j["refuted_impostor"] = refuted.impostor;
  }
  // Only where a server map's writer set them: a file's counters stay as they were.
  const std::pair<const char*, std::int64_t> fleet[] = {{"frame_block_end", frame_block_end},
                                                        {"location_block_end", location_block_end},
                                                        {"word_block_end", word_block_end},
                                                        {"frame_clock_shift", frame_clock_shift}};
  for (const auto& [key, value] : fleet)
    if (value != 0) j[key] = value;
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
    closure_run.anchor = j.value("last_closure_location", std::int64_t{0});
    closure_run.frame = j.value("last_closure_frame", std::int64_t{0});
    closure_run.session = j.value("last_closure_session", std::int64_t{0});
    // Absent from maps made before runs had a heading: a run of one closure.
    closure_run.first = j.value("closure_run_first", closure_run.anchor);
    closure_run.heading = j.value("closure_run_heading", 0);
    // Absent from maps made before evidence added up over frames: no run to continue.
    closure_evidence.location = j.value("evidence_location", std::int64_t{0});
    closure_evidence.frame = j.value("evidence_frame", std::int64_t{0});
    closure_evidence.session = j.value("evidence_session", std::int64_t{0});
    closure_evidence.log10_nfa = j.value("evidence_log10_nfa", 0.0);
    closure_evidence.log10_product = j.value("evidence_log10_product", 0.0);
    closure_evidence.log10_alternatives = j.value("evidence_log10_alternatives", 0.0);
    closure_evidence.frames = j.value("evidence_frames", 0);
    // Absent while no place was refused as a pattern since the map was made.
    refuted.location = j.value("refuted_location", std::int64_t{0});
    refuted.frame = j.value("refuted_frame", std::int64_t{0});
    refuted.session = j.value("refuted_session", std::int64_t{0});
    refuted.impostor = j.value("refuted_impostor", 0.0);
    // Absent from maps made before schema 4, whose ages were the location ids.
    next_wm_age = j.value("next_wm_age", next_location_id);
    // Absent where no block was reserved (every file, and maps before schema 11).
    frame_block_end = j.value("frame_block_end", std::int64_t{0});
    location_block_end = j.value("location_block_end", std::int64_t{0});
    word_block_end = j.value("word_block_end", std::int64_t{0});
    frame_clock_shift = j.value("frame_clock_shift", std::int64_t{0});
    // Absent from maps made before schema 15's checks.
    tiers_digest = j.value("tiers_digest", std::int64_t{0});
  } catch (const nlohmann::json::exception& e) {
    throw Error(ErrorCode::kMapRefused, fmt::format("{}: engine state '{}' is damaged: {}",
                                                    store.path(), kCountersKey, e.what()));
  }
  // Values no page check can judge: an id below 1 would hand out ids the schema reserves.
  const auto require = [&](bool ok, const char* name, auto value, const char* expected) {
    if (!ok)
      throw Error(ErrorCode::kMapRefused,
                  fmt::format("{}: engine state '{}' is damaged: {} = {} ({})", store.path(),
                              kCountersKey, name, value, expected));
  };
  require(next_frame_id >= 1, "next_frame_id", next_frame_id, "at least 1");
  require(next_location_id >= 1, "next_location_id", next_location_id, "at least 1");
  require(next_wm_age >= 1, "next_wm_age", next_wm_age, "at least 1");
  require(frame_block_end == 0 || frame_block_end >= next_frame_id, "frame_block_end",
          frame_block_end, "0 or at least next_frame_id");
  require(location_block_end == 0 || location_block_end >= next_location_id, "location_block_end",
          location_block_end, "0 or at least next_location_id");
  require(word_block_end >= 0, "word_block_end", word_block_end, "not negative");
  require(feature_sum >= 0, "feature_sum", feature_sum, "not negative");
  require(feature_frames >= 0, "feature_frames", feature_frames, "not negative");
  require(last_location >= 0 && last_location < next_location_id, "last_location", last_location,
          "below next_location_id");
  require(std::isfinite(previous_score), "previous_score", previous_score, "a finite number");
  require(std::isfinite(closure_evidence.log10_nfa) && closure_evidence.frames >= 0,
          "evidence_log10_nfa", closure_evidence.log10_nfa, "a finite number");
  return true;
}

void VocabularyStateWriter::save(storage::MapStore& store, vocab::Vocabulary& vocabulary) {
  if (vocabulary.nextWordId() != saved_next_word_id_) {
    vocab::IndexState header;  // Vocabulary::state() without its nodes
    header.dim = vocabulary.dim();
    header.kd_trees = vocabulary.options().kd_trees;
    header.leaf_size = vocabulary.options().leaf_size;
    header.seed = vocabulary.options().seed;
    header.next_word_id = vocabulary.nextWordId();
    store.putState(kVocabularyHeaderKey, header.serialize());
    saved_next_word_id_ = header.next_word_id;
  }
  vocabulary.takeIndexChanges(&changes_);
  if (!changes_.empty()) {
    upserts_.clear();
    deletions_.clear();
    for (const vocab::ForestNode& n : changes_.upserts)
      upserts_.push_back({n.tree, n.node, n.left, n.right, n.dim, n.value});
    for (const auto& [tree, node] : changes_.deletions) deletions_.emplace_back(tree, node);
    store.writeKdNodes(upserts_, deletions_, changes_.full);
  }
  for (std::size_t chunk = 0; chunk < legacy_chunks_; ++chunk)
    store.deleteState(vocabularySplitsKey(chunk));
  legacy_chunks_ = 0;
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
  saved_next_word_id_ = state.next_word_id;
  legacy_chunks_ = 0;
  for (std::size_t chunk = 0;; ++chunk) {
    auto bytes = store.getState(vocabularySplitsKey(chunk));
    if (!bytes) break;
    if (bytes->size() > kSplitsPerChunk * kSplitBytes ||
        !vocab::appendSplitRecords(bytes->data(), bytes->size(), &state.legacy_splits))
      throw Error(ErrorCode::kMapRefused,
                  fmt::format("{}: vocabulary state chunk {} is damaged", store.path(), chunk));
    legacy_chunks_ = chunk + 1;
  }
  if (legacy_chunks_ > 0) saved_next_word_id_ = -1;  // rewrite the header in the new format
  const std::vector<storage::KdNodeRecord> rows = store.loadKdNodes();
  state.nodes.reserve(rows.size());
  for (const storage::KdNodeRecord& r : rows) {
    const auto id_ok = [](std::int64_t v) { return v >= 0 && v <= 0x7fffffff; };
    if (r.tree < 0 || r.tree > 255 || !id_ok(r.node) || !id_ok(r.left_child) ||
        !id_ok(r.right_child) || r.split_dim < 0 || r.split_dim > 65535)
      throw Error(ErrorCode::kMapRefused,
                  fmt::format("{}: kd_nodes row (tree {}, node {}) is damaged", store.path(),
                              r.tree, r.node));
    state.nodes.push_back(
        {static_cast<std::uint8_t>(r.tree), static_cast<std::uint32_t>(r.node),
         static_cast<std::uint32_t>(r.left_child), static_cast<std::uint32_t>(r.right_child),
         static_cast<std::uint16_t>(r.split_dim), static_cast<float>(r.split_value)});
  }
  if (!state.nodes.empty() && !state.legacy_splits.empty())
    throw Error(ErrorCode::kMapRefused,
                store.path() + ": the map holds both a kd_nodes table and a split log");
  return state;
}

}  // namespace placedb
