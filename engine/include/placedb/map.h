#pragma once
// The engine's public face: open a map, process images, read results, close.
//
//   placedb::Options options;                       // or Options::fromSettings(...)
//   auto map = placedb::Map::open("run.placedb", options);
//   map->beginSession("frames.txt");                // or resumeSession(map->lastSession()->id)
//   placedb::FrameResult r = map->process(image, 0, "images/0.png");
//   map->close();                                   // a clean close; the destructor also closes
//
// Every processed frame is committed to the map before process() returns, so a killed process
// loses at most the frame in flight and resumes exactly where it stopped.
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "placedb/error.h"
#include "placedb/options.h"
#include "placedb/storage/records.h"

namespace placedb {

enum class FrameOutcome { kNewLocation = 0, kMerged = 1, kBad = 2 };

struct StageTimes {  // milliseconds
  double features = 0, quantisation = 0, likelihood = 0, filter = 0, memory = 0, storage = 0,
         total = 0;
  double verification = 0;  // the geometric check, part of filter
};

struct FrameRef {  // one input frame that a location covers
  std::int64_t frame_id = 0;
  std::int64_t session_id = 0;
  std::int64_t source_index = 0;
  std::string source_path;
  std::optional<std::int64_t> stamp_ns;  // the stamp given to process() for that frame
};

struct Hypothesis {
  std::int64_t location_id = 0;  // 0: no hypothesis (empty working memory)
  std::vector<FrameRef> frames;  // the frames that location covers
  double posterior = 0;          // the posterior of that location
  double score = 0;              // loop-closure probability, 1 - p(new place)
  bool accepted = false;
  std::string rejected_reason;  // why it was not accepted; empty when accepted
  int inliers = 0;              // the geometric check's epipolar inliers (0: no check ran)
  int matches = 0;              // ... among this many correspondences
  double log10_nfa = 0;         // the check's false alarms, log10 (0: no check; 99: no model)
  int candidates_checked = 0;   // locations the geometric check ran on this frame
  // Frames whose checks the decision combined: 1 = this frame's alone, more when a run of
  // frames matching consecutive places passed together (SPEC's terms: bench/quality/README.md);
  // 0 when no check ran.
  int evidence_frames = 0;
  // An accepted closure's relative pose (this frame's camera in the location's) when the
  // session and the location's session have camera intrinsics (Options::fx ...); none otherwise.
  std::optional<storage::ClosurePose> pose;
};

struct FrameResult {
  std::int64_t frame_id = 0;
  std::int64_t session_id = 0;
  std::int64_t source_index = 0;
  std::optional<std::int64_t> stamp_ns;  // the stamp given to process(), stored with the frame
  FrameOutcome outcome = FrameOutcome::kNewLocation;
  std::int64_t location_id = 0;  // the location holding this frame; 0 when bad
  Hypothesis hypothesis;
  StageTimes times;
  std::size_t feature_count = 0;
  std::size_t words_created = 0;
  std::size_t vocabulary_size = 0;  // words in the kd-index (STM + WM)
  std::size_t stm_size = 0, wm_size = 0;
  std::size_t transferred = 0, retrieved = 0;  // tier moves this frame
  std::size_t retrieved_by_search = 0;         // of the retrieved, found by the LTM search
  double mean_quantisation_error = 0;
};

struct SessionInfo {
  std::int64_t id = 0;
  std::string source;
  std::string started_at, ended_at;  // ISO 8601 UTC; ended_at empty while open or after a crash
  bool clean_close = false;
  std::string source_digest;  // as given to beginSession; empty when none was
  std::int64_t frames = 0;
  std::optional<std::int64_t> last_source_index;  // of the last committed frame
};

// Where a location sits: short-term or working memory (RAM and file) or long-term memory (file).
using Tier = storage::Tier;

struct QueryMatch {  // localisation: a stored location that resembles the query image
  std::int64_t location_id = 0;
  Tier tier = Tier::kWm;
  double similarity = 0;       // eq. 5 against its stored words (LTM: 0 until checked)
  double code_similarity = 0;  // cosine of the place codes, any tier
  int inliers = 0;             // the geometric check's epipolar inliers (0 when it did not run)
  bool verified = false;       // the geometric check passed (geometry_rule)
  std::vector<FrameRef> frames;
  // A verified match's relative pose (the query's camera in the location's) when the map's
  // settings and the location's session both have intrinsics, as a closure's pose.
  std::optional<storage::ClosurePose> pose;
};

// A query's answer: kKnown when its best match passed the geometric check, kUnknown when none
// of the candidates did, kUnverified when the map's settings switch the check off.
enum class QueryVerdict { kKnown, kUnknown, kUnverified };
const char* toString(QueryVerdict verdict);

struct QueryResult {
  std::size_t feature_count = 0;
  QueryVerdict verdict = QueryVerdict::kUnknown;
  std::vector<QueryMatch> matches;  // best first: verified ones by inliers, then by similarity
  std::size_t searched = 0;         // locations compared with the image, all tiers
  std::size_t checked = 0;          // candidates that went through the geometric check
  double time_ms = 0;
};

// How an imported vocabulary serves a map: kFixed never grows (every feature takes its nearest
// word), kSeed is where the map's own vocabulary starts growing from.
enum class VocabularyMode { kFixed, kSeed };

class Map {
 public:
  enum class Mode { kMapping, kLocalisation };

  // Creates the file when missing (mapping mode only), checks and migrates it, and restores
  // short-term and working memory, the vocabulary index and the filter from it.
  // kLocalisation opens read-only and never changes the file.
  static std::unique_ptr<Map> open(const std::string& path, const Options& options,
                                   Mode mode = Mode::kMapping);
  virtual ~Map() = default;

  virtual std::optional<SessionInfo> lastSession() const = 0;
  virtual std::vector<SessionInfo> sessions() const = 0;
  // The settings a session ran with (Options::fromSettings accepts them).
  virtual std::map<std::string, std::string> sessionSettings(std::int64_t session_id) const = 0;

  // Mapping: starts a new session over `source`, or continues an interrupted one with the
  // settings it was started with. `source_digest`, when given, is stored with the session so
  // that a caller can tell later whether the source still holds what it held.
  virtual SessionInfo beginSession(const std::string& source,
                                   const std::string& source_digest = "") = 0;
  virtual SessionInfo resumeSession(std::int64_t session_id) = 0;

  // One frame: features, quantisation, STM, filter, memory management, one committed
  // transaction. An image too poor in features is recorded as a bad frame. `stamp_ns`, the
  // source's time stamp of the frame (a bag message's header.stamp, ns since the epoch), is
  // stored with it (frames.stamp_ns).
  virtual FrameResult process(const cv::Mat& image, std::int64_t source_index,
                              const std::string& source_path,
                              std::optional<std::int64_t> stamp_ns = std::nullopt) = 0;
  // A frame that could not be read: recorded as bad, with the reason in the log only.
  virtual FrameResult recordUnreadable(std::int64_t source_index, const std::string& source_path,
                                       std::optional<std::int64_t> stamp_ns = std::nullopt) = 0;

  // Localisation against the locations of every tier (STM, WM and LTM); changes nothing.
  virtual QueryResult query(const cv::Mat& image, std::size_t top_k = 5) = 0;

  // Starts the vocabulary of a new map (no frames, no words) from a vocabulary file: placedb's
  // binary format, or with `text` RTAB-Map's "WordID d1 ... dN" lines. The file is read and
  // checked whole (kVocabularyRefused, naming the reason: magic, version, checksum, truncation,
  // dimension, extractor) before anything is written; the import is one transaction. Imported
  // words stay in the index whatever the memory tiers do. Returns the number of words.
  virtual std::size_t importVocabulary(const std::string& file, bool text, VocabularyMode mode) = 0;

  // Ends the session cleanly. Safe to call twice.
  virtual void close() = 0;

  virtual const Options& options() const = 0;
  virtual const std::string& path() const = 0;
};

}  // namespace placedb
