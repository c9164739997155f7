#pragma once
// MapStore: one placedb map file (SQLite) opened for reading and writing or for inspection.
//
// Opening read-write creates a missing map, refuses files that are not SQLite, SQLite files
// that are not placedb maps and maps newer than this binary (ErrorCode::kMapRefused, file left
// untouched), takes an exclusive advisory lock (a second writer gets kMapBusy) and then applies
// the missing migrations. Every method that writes runs inside the open Transaction, or in one
// of its own when none is open. All failures throw StorageError (a placedb::Error).
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "placedb/storage/records.h"
#include "placedb/storage/storage_error.h"

namespace placedb::storage {

namespace detail {
class Database;
class WalCheckpointer;
}  // namespace detail

enum class OpenMode { kReadWrite, kReadOnly };

struct OpenOptions {
  // How long a write waits for another connection's lock before kMapBusy.
  int busy_timeout_ms = 5000;
  // When > 0, caps the file at this many pages (SQLite's max_page_count): for disk-full tests.
  std::int64_t max_page_count = 0;
  // A read-write open reads every page first (PRAGMA quick_check) on maps up to this size, so a
  // damaged map is refused before anything is written to it. The check costs ~1-2 s a GB of
  // CPU (more when the file is not cached), which would make reopening a large map slow
  // whatever its working memory; larger maps rely on SQLITE_CORRUPT met while mapping (the frame
  // is rolled back, exit 4) and on `sqlite3 MAP 'pragma quick_check'`. 0 checks every size.
  std::int64_t integrity_check_max_bytes = std::int64_t{256} << 20;
};

// BEGIN IMMEDIATE on construction; rolls back on destruction unless committed.
class Transaction {
 public:
  Transaction(Transaction&& other) noexcept;
  Transaction& operator=(Transaction&&) = delete;
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  ~Transaction();

  void commit();
  void rollback();
  bool active() const { return db_ != nullptr; }

 private:
  friend class MapStore;
  explicit Transaction(detail::Database* db);
  detail::Database* db_;
};

// A read transaction (BEGIN DEFERRED): many reads see one snapshot and share one lock, instead
// of taking and dropping a read lock per statement. Ends on destruction; no-op when the
// connection is already inside a transaction.
class ReadSnapshot {
 public:
  ReadSnapshot(ReadSnapshot&& other) noexcept;
  ReadSnapshot& operator=(ReadSnapshot&&) = delete;
  ReadSnapshot(const ReadSnapshot&) = delete;
  ReadSnapshot& operator=(const ReadSnapshot&) = delete;
  ~ReadSnapshot();

 private:
  friend class MapStore;
  explicit ReadSnapshot(detail::Database* db);
  detail::Database* db_;
};

class MapStore {
 public:
  MapStore(const std::string& path, OpenMode mode, const OpenOptions& options = {});
  ~MapStore();
  MapStore(const MapStore&) = delete;
  MapStore& operator=(const MapStore&) = delete;

  const std::string& path() const { return path_; }
  bool readOnly() const { return read_only_; }
  int schemaVersion() const;
  static int currentSchemaVersion();

  // One per processed frame: everything written for the frame commits together.
  Transaction begin();
  // For loading many rows at once (restoring memory on open), also on a read-only map.
  ReadSnapshot readSnapshot() const;

  // Sessions.
  std::int64_t beginSession(const std::string& source,
                            const std::map<std::string, std::string>& settings,
                            const std::string& software_version);
  void setSourceDigest(std::int64_t session_id, const std::string& digest);
  void endSession(std::int64_t session_id, bool clean);
  // Marks an ended session as running again (a resumed session): ended_at NULL, not clean.
  void reopenSession(std::int64_t session_id);
  std::vector<SessionRecord> sessions() const;
  std::optional<SessionRecord> lastSession() const;
  std::map<std::string, std::string> settings(std::int64_t session_id) const;

  // Frames. A record with id 0 gets the next id from the database; a non-zero id is kept.
  // Within a transaction frames, words, locations and hypotheses may reference each other in
  // any insertion order: those foreign keys are checked at commit.
  std::int64_t insertFrame(const FrameRecord& frame);
  std::optional<FrameRecord> frame(std::int64_t frame_id) const;
  std::vector<FrameRecord> frames(std::int64_t session_id) const;  // by source index
  std::optional<std::int64_t> lastFrameIndex(std::int64_t session_id) const;
  std::int64_t frameCount() const;
  std::int64_t frameCount(std::int64_t session_id) const;
  std::int64_t frameCount(FrameOutcome outcome) const;
  std::optional<FrameRecord> lastFrame() const;  // the newest, over all sessions

  // Locations.
  void insertLocation(const LocationRecord& location);
  void updateWeight(std::int64_t location_id, std::int64_t weight);
  void setTier(const std::vector<std::int64_t>& location_ids, Tier tier);
  // Removes the location with its references, coverage and links (frames keep NULL).
  void deleteLocation(std::int64_t location_id);
  void addCoveredFrame(std::int64_t location_id, std::int64_t frame_id);
  std::vector<std::int64_t> coveredFrames(std::int64_t location_id) const;
  std::map<std::int64_t, std::vector<std::int64_t>> coveredFrames(
      const std::vector<std::int64_t>& location_ids) const;
  std::vector<LocationWeight> locationsInTier(Tier tier) const;  // by id
  std::optional<LocationRecord> location(std::int64_t location_id) const;
  std::int64_t locationCount() const;

  // Words.
  void insertWords(const std::vector<WordRecord>& words);
  // The words found, in the order asked; unknown ids are skipped.
  std::vector<WordRecord> loadWords(const std::vector<std::int64_t>& word_ids) const;
  // Bulk form for loading an index: word_ids[i]'s float32 descriptor of `dim` values goes to row
  // i of `rows` (word_ids.size() x dim, contiguous) and its creating frame (or -1) to
  // created[i]. A word that is missing, or of another type or dimension, is kMapRefused.
  void loadFloatDescriptors(const std::vector<std::int64_t>& word_ids, int dim, float* rows,
                            std::int64_t* created) const;
  std::int64_t wordCount() const;
  std::optional<std::int64_t> maxWordId() const;
  // Words of imported vocabularies, ascending: they stay in the index whatever the tiers do.
  std::vector<std::int64_t> importedWordIds() const;

  // Word references: a location's signature, kept in insertion order.
  void insertWordRefs(std::int64_t location_id, const std::vector<WordRef>& refs);
  void replaceWordRefs(std::int64_t location_id, const std::vector<WordRef>& refs);
  std::vector<WordRef> loadWordRefs(std::int64_t location_id) const;
  std::map<std::int64_t, std::vector<WordRef>> loadWordRefs(
      const std::vector<std::int64_t>& location_ids) const;
  // Only the word ids of each location's references, in order: a signature without keypoints.
  std::map<std::int64_t, std::vector<std::int64_t>> loadWordIds(
      const std::vector<std::int64_t>& location_ids) const;
  std::vector<std::int64_t> wordsOfLocations(const std::vector<std::int64_t>& location_ids) const;
  // The inverted index: locations whose signature holds the word, ascending.
  std::vector<std::int64_t> locationsOfWord(std::int64_t word_id) const;

  // Links, stored once per unordered pair and type; inserting again updates the score.
  void insertLink(std::int64_t a, std::int64_t b, LinkType type, std::optional<double> score);
  std::vector<LinkRecord> links(std::int64_t location_id) const;
  // Every link of one type, by (location_a, location_b).
  std::vector<LinkRecord> linksOfType(LinkType type) const;
  std::int64_t linkCount(LinkType type) const;
  // Frames whose loop-closure hypothesis was accepted (several frames merged into one location
  // that close on one place make one loop-closure link); `posed`: only those with a pose.
  std::int64_t acceptedClosureCount(bool posed = false) const;
  // Locations linked to `location_id` (by `type`, or any link) that sit in `tier`, ascending.
  std::vector<std::int64_t> linkedInTier(std::int64_t location_id, Tier tier,
                                         std::optional<LinkType> type = std::nullopt) const;

  // Loop-closure hypotheses, one per frame.
  void insertHypothesis(const HypothesisRecord& hypothesis);
  std::optional<HypothesisRecord> hypothesis(std::int64_t frame_id) const;
  // Every accepted hypothesis that carries a pose (schema 7), by frame id.
  std::vector<ClosurePoseRecord> closurePoses() const;

  // Engine state for an exact resume.
  void putState(const std::string& key, const std::vector<std::uint8_t>& value);
  void putState(const std::string& key, const std::string& value);
  std::optional<std::vector<std::uint8_t>> getState(const std::string& key) const;
  std::optional<std::string> getStateText(const std::string& key) const;
  void deleteState(const std::string& key);
  // The vocabulary's kd-forest: upserts and deletes nodes by (tree, node); with replace_all the
  // table is emptied first. loadKdNodes() returns every node, by tree and node.
  void writeKdNodes(const std::vector<KdNodeRecord>& upserts,
                    const std::vector<std::pair<int, std::int64_t>>& deletions, bool replace_all);
  std::vector<KdNodeRecord> loadKdNodes() const;
  // Replaces the whole stored posterior.
  void putPosterior(const std::vector<std::pair<std::int64_t, double>>& posterior);
  std::vector<std::pair<std::int64_t, double>> loadPosterior() const;  // by location id

  // Memory tiers (schema 4). Every location's place code, whatever its tier; and its age in the
  // transfer order (the order of entering STM/WM; a location brought back from LTM enters again).
  void putPlaceCode(std::int64_t location_id, const std::vector<std::int8_t>& code);
  std::vector<PlaceCodeRecord> placeCodes() const;  // by location id
  std::optional<std::vector<std::int8_t>> placeCode(std::int64_t location_id) const;
  void setWmAges(const std::vector<std::pair<std::int64_t, std::int64_t>>& ages);
  // Every location's age; its id where none was stored (maps made before schema 4).
  std::map<std::int64_t, std::int64_t> wmAges() const;

  // Vocabulary imports. imported_at is set to now when empty.
  std::int64_t recordVocabularyImport(const VocabularyImportRecord& import);
  std::vector<VocabularyImportRecord> vocabularyImports() const;

 private:
  class WriteScope;
  void requireWritable() const;
  // kd_nodes' row count as the map recorded it (engine_state); refuses the map when damaged.
  std::int64_t storedKdNodeRows() const;

  std::string path_;
  bool read_only_;
  int lock_fd_ = -1;  // holds the writer's advisory lock
  std::unique_ptr<detail::Database> db_;
  std::unique_ptr<detail::WalCheckpointer> checkpointer_;  // writers only
};

}  // namespace placedb::storage
