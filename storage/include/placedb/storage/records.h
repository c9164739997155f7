#pragma once
// Plain records exchanged between the engine and the map database. Ids are SQLite integers.
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace placedb::storage {

// Where a location is: short-term, working or long-term memory (the engine's MemoryTiers use
// this same enum; the numbers are what the locations table stores).
enum class Tier : std::uint8_t { kStm = 0, kWm = 1, kLtm = 2 };
const char* toString(Tier tier);  // "stm", "wm", "ltm"
enum class FrameOutcome : int { kNewLocation = 0, kMerged = 1, kBad = 2 };
enum class LinkType : int { kNeighbour = 0, kLoopClosure = 1, kMerge = 2 };
enum class VocabularyMode : int { kFixed = 0, kSeed = 1 };
// Same numbering as placedb::DescriptorType.
enum class DescriptorKind : std::uint8_t { kFloat32 = 0, kBinary8U = 1 };

struct SessionRecord {
  std::int64_t id = 0;
  std::string started_at;               // ISO 8601 UTC, set by the database
  std::optional<std::string> ended_at;  // empty while running or after a crash
  bool clean_close = false;
  std::string software_version;
  std::string source;
  // What the source held when the session began (see Map::beginSession); nullopt: not recorded.
  std::optional<std::string> source_digest;
};

struct FrameTimings {  // milliseconds per stage
  double features_ms = 0, quantisation_ms = 0, likelihood_ms = 0, filter_ms = 0, memory_ms = 0,
         storage_ms = 0, total_ms = 0;
};

struct FrameStats {
  std::int64_t feature_count = 0, words_created = 0, vocabulary_size = 0, wm_size = 0, stm_size = 0;
  double mean_quantisation_error = 0;
};

struct FrameRecord {
  std::int64_t id = 0;  // 0 on insert: the database assigns it; otherwise used as given
  std::int64_t session_id = 0;
  std::int64_t source_index = 0;  // index of the image in its source
  std::string source_path;
  FrameOutcome outcome = FrameOutcome::kNewLocation;
  std::optional<std::int64_t> location_id;  // the location holding the frame; none when bad
  FrameTimings timings;
  FrameStats stats;
  std::optional<std::int64_t> stamp_ns;  // the source's time stamp (a bag's header.stamp)
};

struct LocationRecord {
  std::int64_t id = 0;  // assigned by the engine
  std::int64_t session_id = 0;
  std::int64_t weight = 0;
  Tier tier = Tier::kStm;
  std::optional<std::int64_t> created_frame;
};

struct PlaceCodeRecord {
  std::int64_t location_id = 0;
  std::vector<std::int8_t> code;
};

struct LocationWeight {
  std::int64_t id = 0;
  std::int64_t weight = 0;
};

struct WordRecord {
  std::int64_t id = 0;
  std::optional<std::int64_t> created_frame;         // none for imported words
  std::optional<std::int64_t> vocabulary_import_id;  // set for imported words
  DescriptorKind type = DescriptorKind::kFloat32;
  int dim = 0;
  std::vector<std::uint8_t> descriptor;      // dim values of `type`, little-endian
  std::optional<std::int64_t> source_frame;  // imported words: creating frame in the source map

  static WordRecord fromFloats(std::int64_t id, std::optional<std::int64_t> created_frame,
                               const float* values, int dim);
  // The descriptor as floats; throws placedb::Error(kInternal) when type is not kFloat32.
  std::vector<float> floats() const;
};

// The descriptors of a location's words, stored beside it (schema 13, table
// location_word_descriptors) so that bringing it back from long-term memory is one read: copies
// of words rows. Row i of `descriptors` (dim floats) is word_ids[i]'s.
struct LocationWordDescriptors {
  std::int64_t location_id = 0;
  int dim = 0;
  std::vector<std::int64_t> word_ids;        // ascending, distinct
  std::vector<std::int64_t> created_frames;  // per word: its created_frame, -1 for none
  std::vector<float> descriptors;            // word_ids.size() x dim

  // The table's `words` bytes: every id, every created frame (int64), every value (float32),
  // little-endian.
  std::vector<std::uint8_t> encode() const;
  // From a row's bytes; false, leaving the record unchanged, when their size is not a whole
  // number of words of `dim` values, or the ids do not ascend.
  bool decode(std::int64_t location, int dimension, const std::uint8_t* data, std::size_t size);
};

// The engine_state key of a location's keypoint descriptors, "keypoint_descriptors/<id>": a row
// the location holds (schema 15, locations.held), so storage names it; the engine writes it
// (engine/src/map/state_keys.h).
inline constexpr const char* kLocationKeypointsKeyPrefix = "keypoint_descriptors/";
std::string locationKeypointsKey(std::int64_t location_id);
// The location a key of that form names; none for any other key.
std::optional<std::int64_t> locationOfKeypointsKey(const std::string& key);
// The engine_state key of the view of the latest frame merged into a location,
// "latest_view/<id>" (engine/src/geometry/latest_view.h): the engine writes it at each merge,
// and it goes when the location does.
inline constexpr const char* kLocationLatestViewKeyPrefix = "latest_view/";
std::string locationLatestViewKey(std::int64_t location_id);

struct WordRef {  // one keypoint of a location's signature quantised to a word
  std::int64_t word_id = 0;
  float x = 0, y = 0, size = 0, angle = 0, response = 0;
};

struct LinkRecord {  // stored with location_a < location_b
  std::int64_t location_a = 0;
  std::int64_t location_b = 0;
  LinkType type = LinkType::kNeighbour;
  std::optional<double> score;
};

// An accepted loop closure's relative pose (schema 7): the frame's camera in the camera of the
// hypothesis' location. A point X in the frame's camera is R X + s t in the location's, for an
// unknown scale s > 0 (one camera measures none).
struct ClosurePose {
  double qw = 1, qx = 0, qy = 0, qz = 0;  // R as a unit quaternion
  double tx = 0, ty = 0, tz = 0;          // t, unit length; 0 0 0 when the camera did not move
  std::int64_t inliers = 0;               // pairs that agreed with the essential matrix
};

struct HypothesisRecord {
  std::int64_t frame_id = 0;
  std::optional<std::int64_t> best_location_id;
  double posterior = 0;
  double loop_probability = 0;
  bool accepted = false;
  std::string rejected_reason;      // empty when accepted or not applicable (stored as NULL)
  std::optional<ClosurePose> pose;  // none without intrinsics (stored as NULL)
};

// A row of v_loop_closure_poses: the hypothesis of frame_id, made at frame_location_id, named
// hypothesis_location_id and was accepted with a pose.
struct ClosurePoseRecord {
  std::int64_t frame_id = 0;
  std::int64_t frame_location_id = 0;
  std::int64_t hypothesis_location_id = 0;
  ClosurePose pose;
};

// One internal node of the vocabulary's kd-forest (table kd_nodes).
struct KdNodeRecord {
  int tree = 0;
  std::int64_t node = 0;
  std::int64_t left_child = 0;
  std::int64_t right_child = 0;
  int split_dim = 0;
  double split_value = 0;  // points whose descriptor[split_dim] < split_value go left
};

struct VocabularyImportRecord {
  std::int64_t id = 0;  // assigned by the database
  std::optional<std::int64_t> session_id;
  std::string file;
  std::string checksum;
  std::int64_t word_count = 0;
  VocabularyMode mode = VocabularyMode::kFixed;
  std::string imported_at;  // ISO 8601 UTC, set by the database when empty
  // What the file's header said (schema 2); empty for imports recorded before.
  std::string extractor;
  std::string distance_unit;
  std::map<std::string, std::string> settings;
};

}  // namespace placedb::storage
