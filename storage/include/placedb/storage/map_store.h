#pragma once
// MapStore: one placedb map opened for reading and writing or for inspection. The interface the
// engine and the tools use; two backends implement it: a SQLite file (SqliteMapStore,
// sqlite_map_store.h) and a PostgreSQL database named by a libpq URI (storage/src/postgres/).
// openMapStore() picks one from the map's name, so nothing above storage knows which it has.
//
// Opening read-write creates a missing map, refuses what is not a placedb map and maps newer
// than this binary (ErrorCode::kMapRefused, left untouched), takes the map's exclusive writer
// lock (a second writer gets kMapBusy) and then applies the missing migrations. Every method
// that writes runs inside the open Transaction, or in one of its own when none is open. All
// failures throw StorageError (a placedb::Error) whose message names the map.
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "placedb/storage/map_copy.h"
#include "placedb/storage/records.h"
#include "placedb/storage/storage_error.h"

namespace placedb::storage {

enum class OpenMode { kReadWrite, kReadOnly };

struct OpenOptions {
  // How long a write waits for another connection's lock before kMapBusy (SQLite).
  int busy_timeout_ms = 5000;
  // When > 0, caps the file at this many pages (SQLite's max_page_count): for disk-full tests.
  std::int64_t max_page_count = 0;
  // A read-write open reads every page first (PRAGMA quick_check) on maps up to this size, so a
  // damaged map is refused before anything is written to it. The check costs ~1-2 s a GB of
  // CPU (more when the file is not cached), which would make reopening a large map slow
  // whatever its working memory; larger maps rely on SQLITE_CORRUPT met while mapping (the frame
  // is rolled back, exit 4) and on `sqlite3 MAP 'pragma quick_check'`. 0 checks every size.
  // (SQLite only: a PostgreSQL server checks its own pages.)
  std::int64_t integrity_check_max_bytes = std::int64_t{256} << 20;
  // A read-only open (SQLite) of a map up to integrity_check_max_bytes also looks up every
  // foreign key (PRAGMA foreign_key_check), as a read-write open does with its page check: the
  // engine asks for it when it opens a map to answer queries, so that a map `map` refuses is
  // not answered from either. (A server enforces its keys itself.)
  bool check_references = false;
  // PostgreSQL: how long connecting may take before kServerUnreachable.
  int connect_timeout_s = 10;
  // PostgreSQL: a read-write open when another writer holds the map's main line opens anyway,
  // for a session of its own (MapStore::beginSideSession), instead of kMapBusy. The engine sets
  // it; a tool that needs the map to itself (copy, vocabulary import) does not.
  bool side_writer = false;
};

// ---- Fleet maps: several writers at once (schema/SCHEMA.md, "Fleet maps") ----

// The ids a writer hands out: frames, locations and words.
enum class IdKind { kFrame, kLocation, kWord };

// A block of ids reserved by one writer: [first, end).
struct IdBlock {
  std::int64_t first = 0;
  std::int64_t end = 0;
};

// Where a session's memory (its engine state, tiers, filter, kd-forest) is kept, which decides
// whether it can be resumed: on the main line (the map-wide tables, continued by one writer at a
// time: only its newest session resumes), in rows of its own (a side session of a fleet map), or
// nowhere any more (a later session continued the main line).
enum class SessionMemory { kGone, kMainLine, kOwn };

// A place another writer stored: its location, session, weight and place code (empty when the
// location predates place codes).
struct SharedPlace {
  std::int64_t location_id = 0;
  std::int64_t session_id = 0;
  std::int64_t weight = 0;
  std::vector<std::int8_t> code;
};

// True for the keys of engine_state that hold a writer's own memory ("engine.counters",
// "vocabulary.header", "storage.kd_nodes.rows"): a side session keeps its own.
bool isWriterStateKey(const std::string& key);
const std::vector<std::string>& writerStateKeys();

// True when `map` names a map on a PostgreSQL server (a libpq URI: postgresql:// or
// postgres://) rather than a file.
bool isServerMap(const std::string& map);

// The name of `map` to show in messages: a file path as given; a server URI without its password
// (the user:password part loses ":password", a password= parameter is dropped).
std::string mapDisplayName(const std::string& map);

// The password a server URI holds (user:password@ or password=, percent-decoded), or "".
std::string mapPassword(const std::string& map);

// Opens the map `map` names: a PostgreSQL map for a server URI, a SQLite file otherwise.
class MapStore;
std::unique_ptr<MapStore> openMapStore(const std::string& map, OpenMode mode,
                                       const OpenOptions& options = {});

// One backend connection's transactions, as Transaction and ReadSnapshot drive them.
class TransactionControl {
 public:
  virtual ~TransactionControl() = default;
  virtual bool inTransaction() const = 0;
  // A write transaction: kMapBusy when another connection keeps the map's write lock too long.
  virtual void beginWrite() = 0;
  // On failure no transaction is left open: the frame vanishes as a whole.
  virtual void commit() = 0;
  virtual void rollback() = 0;
  // For destructors: never throws.
  virtual void rollbackQuietly() noexcept = 0;
  // A read transaction: one snapshot for many reads.
  virtual void beginRead() = 0;
  virtual void endReadQuietly() noexcept = 0;
  // The map's name, for messages.
  virtual const std::string& label() const = 0;
};

// Begins a write transaction on construction; rolls back on destruction unless committed.
class Transaction {
 public:
  explicit Transaction(TransactionControl* control);
  Transaction(Transaction&& other) noexcept;
  Transaction& operator=(Transaction&&) = delete;
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  ~Transaction();

  void commit();
  void rollback();
  bool active() const { return control_ != nullptr; }

 private:
  TransactionControl* control_;
};

// A read transaction: many reads see one snapshot and share one lock, instead of taking and
// dropping a read lock per statement. Ends on destruction; no-op when the connection is already
// inside a transaction.
class ReadSnapshot {
 public:
  explicit ReadSnapshot(TransactionControl* control);
  ReadSnapshot(ReadSnapshot&& other) noexcept;
  ReadSnapshot& operator=(ReadSnapshot&&) = delete;
  ReadSnapshot(const ReadSnapshot&) = delete;
  ReadSnapshot& operator=(const ReadSnapshot&) = delete;
  ~ReadSnapshot();

 private:
  TransactionControl* control_;
};

namespace detail {

// Runs a MapStore write in the caller's transaction, or in one of its own when none is open.
class WriteScope {
 public:
  explicit WriteScope(TransactionControl& control) {
    if (!control.inTransaction()) own_.emplace(&control);
  }
  void commit() {
    if (own_) own_->commit();
  }

 private:
  std::optional<Transaction> own_;
};

}  // namespace detail

class MapStore {
 public:
  MapStore() = default;
  virtual ~MapStore() = default;
  MapStore(const MapStore&) = delete;
  MapStore& operator=(const MapStore&) = delete;

  // The map's name for messages: the file path, or the server URI without its password.
  virtual const std::string& path() const = 0;
  virtual bool readOnly() const = 0;
  virtual int schemaVersion() const = 0;
  static int currentSchemaVersion();

  // One per processed frame: everything written for the frame commits together.
  virtual Transaction begin() = 0;
  // For loading many rows at once (restoring memory on open), also on a read-only map.
  virtual ReadSnapshot readSnapshot() const = 0;

  // Sessions.
  virtual std::int64_t beginSession(const std::string& source,
                                    const std::map<std::string, std::string>& settings,
                                    const std::string& software_version) = 0;
  virtual void setSourceDigest(std::int64_t session_id, const std::string& digest) = 0;
  virtual void endSession(std::int64_t session_id, bool clean) = 0;
  // Marks an ended session as running again (a resumed session): ended_at NULL, not clean.
  virtual void reopenSession(std::int64_t session_id) = 0;
  virtual std::vector<SessionRecord> sessions() const = 0;
  virtual std::optional<SessionRecord> lastSession() const = 0;
  virtual std::map<std::string, std::string> settings(std::int64_t session_id) const = 0;

  // Frames. A record with id 0 gets the next id from the database; a non-zero id is kept.
  // Within a transaction frames, words, locations and hypotheses may reference each other in
  // any insertion order: those foreign keys are checked at commit.
  virtual std::int64_t insertFrame(const FrameRecord& frame) = 0;
  virtual std::optional<FrameRecord> frame(std::int64_t frame_id) const = 0;
  virtual std::vector<FrameRecord> frames(std::int64_t session_id) const = 0;  // by source index
  virtual std::optional<std::int64_t> lastFrameIndex(std::int64_t session_id) const = 0;
  virtual std::int64_t frameCount() const = 0;
  virtual std::int64_t frameCount(std::int64_t session_id) const = 0;
  virtual std::int64_t frameCount(FrameOutcome outcome) const = 0;
  virtual std::optional<FrameRecord> lastFrame() const = 0;  // the newest, over all sessions

  // Locations.
  virtual void insertLocation(const LocationRecord& location) = 0;
  virtual void updateWeight(std::int64_t location_id, std::int64_t weight) = 0;
  virtual void setTier(const std::vector<std::int64_t>& location_ids, Tier tier) = 0;
  // Removes the location with its references, coverage, links and engine_state rows (its
  // keypoint descriptors and latest view; frames keep NULL).
  virtual void deleteLocation(std::int64_t location_id) = 0;
  virtual void addCoveredFrame(std::int64_t location_id, std::int64_t frame_id) = 0;
  virtual std::vector<std::int64_t> coveredFrames(std::int64_t location_id) const = 0;
  virtual std::map<std::int64_t, std::vector<std::int64_t>> coveredFrames(
      const std::vector<std::int64_t>& location_ids) const = 0;
  virtual std::vector<LocationWeight> locationsInTier(Tier tier) const = 0;  // by id
  virtual std::optional<LocationRecord> location(std::int64_t location_id) const = 0;
  virtual std::int64_t locationCount() const = 0;

  // Words.
  virtual void insertWords(const std::vector<WordRecord>& words) = 0;
  // The words found, in the order asked; unknown ids are skipped.
  virtual std::vector<WordRecord> loadWords(const std::vector<std::int64_t>& word_ids) const = 0;
  // Bulk form for loading an index: word_ids[i]'s float32 descriptor of `dim` values goes to row
  // i of `rows` (word_ids.size() x dim, contiguous) and its creating frame (or -1) to
  // created[i]. A word that is missing, or of another type or dimension, is kMapRefused.
  virtual void loadFloatDescriptors(const std::vector<std::int64_t>& word_ids, int dim, float* rows,
                                    std::int64_t* created) const = 0;
  // The descriptors of a location's words, stored beside it (schema 13): written with the
  // location, read back for the locations that have a row, in the order asked (checksums and
  // values verified, as words rows are).
  virtual void putLocationWordDescriptors(const LocationWordDescriptors& words) = 0;
  virtual std::vector<LocationWordDescriptors> locationWordDescriptors(
      const std::vector<std::int64_t>& location_ids) const = 0;
  // loadFloatDescriptors() of words in the signatures of `location_ids` (bringing them back from
  // long-term memory): from the locations' own rows where those hold them, one read a location,
  // the rest from the words table.
  void loadLocationDescriptors(const std::vector<std::int64_t>& location_ids,
                               const std::vector<std::int64_t>& word_ids, int dim, float* rows,
                               std::int64_t* created) const;
  virtual std::int64_t wordCount() const = 0;
  virtual std::optional<std::int64_t> maxWordId() const = 0;
  // Words of imported vocabularies, ascending: they stay in the index whatever the tiers do.
  virtual std::vector<std::int64_t> importedWordIds() const = 0;

  // Word references: a location's signature, kept in insertion order.
  virtual void insertWordRefs(std::int64_t location_id, const std::vector<WordRef>& refs) = 0;
  virtual void replaceWordRefs(std::int64_t location_id, const std::vector<WordRef>& refs) = 0;
  virtual std::vector<WordRef> loadWordRefs(std::int64_t location_id) const = 0;
  virtual std::map<std::int64_t, std::vector<WordRef>> loadWordRefs(
      const std::vector<std::int64_t>& location_ids) const = 0;
  // Only the word ids of each location's references, in order: a signature without keypoints.
  virtual std::map<std::int64_t, std::vector<std::int64_t>> loadWordIds(
      const std::vector<std::int64_t>& location_ids) const = 0;
  virtual std::vector<std::int64_t> wordsOfLocations(
      const std::vector<std::int64_t>& location_ids) const = 0;
  // The inverted index: locations whose signature holds the word, ascending.
  virtual std::vector<std::int64_t> locationsOfWord(std::int64_t word_id) const = 0;

  // Links, stored once per unordered pair and type; inserting again updates the score.
  virtual void insertLink(std::int64_t a, std::int64_t b, LinkType type,
                          std::optional<double> score) = 0;
  virtual std::vector<LinkRecord> links(std::int64_t location_id) const = 0;
  // Every link of one type, by (location_a, location_b).
  virtual std::vector<LinkRecord> linksOfType(LinkType type) const = 0;
  virtual std::int64_t linkCount(LinkType type) const = 0;
  // Frames whose loop-closure hypothesis was accepted (several frames merged into one location
  // that close on one place make one loop-closure link); `posed`: only those with a pose.
  virtual std::int64_t acceptedClosureCount(bool posed = false) const = 0;
  // Locations linked to `location_id` (by `type`, or any link) that sit in `tier`, ascending.
  virtual std::vector<std::int64_t> linkedInTier(
      std::int64_t location_id, Tier tier, std::optional<LinkType> type = std::nullopt) const = 0;

  // Loop-closure hypotheses, one per frame.
  virtual void insertHypothesis(const HypothesisRecord& hypothesis) = 0;
  virtual std::optional<HypothesisRecord> hypothesis(std::int64_t frame_id) const = 0;
  // Every accepted hypothesis that carries a pose (schema 7), by frame id.
  virtual std::vector<ClosurePoseRecord> closurePoses() const = 0;

  // Engine state for an exact resume.
  virtual void putState(const std::string& key, const std::vector<std::uint8_t>& value) = 0;
  virtual void putState(const std::string& key, const std::string& value) = 0;
  virtual std::optional<std::vector<std::uint8_t>> getState(const std::string& key) const = 0;
  virtual std::optional<std::string> getStateText(const std::string& key) const = 0;
  virtual void deleteState(const std::string& key) = 0;
  // The vocabulary's kd-forest: upserts and deletes nodes by (tree, node); with replace_all the
  // table is emptied first. loadKdNodes() returns every node, by tree and node.
  virtual void writeKdNodes(const std::vector<KdNodeRecord>& upserts,
                            const std::vector<std::pair<int, std::int64_t>>& deletions,
                            bool replace_all) = 0;
  virtual std::vector<KdNodeRecord> loadKdNodes() const = 0;
  // Replaces the whole stored posterior.
  virtual void putPosterior(const std::vector<std::pair<std::int64_t, double>>& posterior) = 0;
  virtual std::vector<std::pair<std::int64_t, double>> loadPosterior() const = 0;  // by location id

  // Memory tiers (schema 4). Every location's place code, whatever its tier; and its age in the
  // transfer order (the order of entering STM/WM; a location brought back from LTM enters again).
  virtual void putPlaceCode(std::int64_t location_id, const std::vector<std::int8_t>& code) = 0;
  virtual std::vector<PlaceCodeRecord> placeCodes() const = 0;  // by location id
  virtual std::optional<std::vector<std::int8_t>> placeCode(std::int64_t location_id) const = 0;
  virtual void setWmAges(const std::vector<std::pair<std::int64_t, std::int64_t>>& ages) = 0;
  // Every location's age; its id where none was stored (maps made before schema 4).
  virtual std::map<std::int64_t, std::int64_t> wmAges() const = 0;

  // Whether every location holds the rows it must (schema 15, locations.held: its place code,
  // word descriptors, keypoint descriptors and WM age row) and no others, a valid tier and its
  // row's checksum, and every session its settings (settings_digest).
  // Throws kMapRefused naming the table and row. The engine runs it when it opens a map: a scan
  // of locations and key lookups, no BLOB read. (A location's references are checked against its
  // refs_digest whenever they are read.)
  virtual void checkStoredRows() const = 0;

  // Vocabulary imports. imported_at is set to now when empty.
  virtual std::int64_t recordVocabularyImport(const VocabularyImportRecord& import) = 0;
  virtual std::vector<VocabularyImportRecord> vocabularyImports() const = 0;

  // Whole tables, for copyMap(): every row of `t` in primary-key order, and rows written as
  // they are (no checksums computed: a copy keeps the sums it read).
  virtual void readTable(const TableColumns& t,
                         const std::function<void(const TableRow&)>& row) const = 0;
  virtual void writeRows(const TableColumns& t, const std::vector<TableRow>& rows) = 0;

  // ---- Writers (schema/SCHEMA.md, "Fleet maps") ----
  // A file has one writer: it holds the main line (the memory in the map-wide tables) and hands
  // out ids from its own counters. A map on a server may have several writers at once, each in
  // its own session: one continues the main line, the others keep their memory in rows of their
  // own (side sessions), and all take their ids from blocks reserved in id_blocks.

  // True when other writers may write this map while this one does (a map on a server).
  virtual bool sharedByWriters() const = 0;
  // Takes the main line if no other writer holds it (a server map's writer lock); true when
  // this writer holds it. A file's writer always does.
  virtual bool claimMainLine() = 0;
  virtual void releaseMainLine() = 0;
  virtual SessionMemory sessionMemory(std::int64_t session_id) const = 0;
  // Takes the session for this writer until releaseSession() or the store closes: kMapBusy when
  // another writer has it (a second writer of one session). Nothing to take on a file.
  virtual void claimSession(std::int64_t session_id) = 0;
  virtual void releaseSession(std::int64_t session_id) = 0;
  // In the open transaction: a new session (as beginSession) whose memory is a copy of the main
  // line's, taken in one snapshot into rows of its own; the session is claimed and, from here
  // on, this store reads and writes that memory (useSideMemory). A file refuses (kInternal).
  virtual std::int64_t beginSideSession(const std::string& source,
                                        const std::map<std::string, std::string>& settings,
                                        const std::string& software_version) = 0;
  // In the open transaction, by the writer that holds the main line, before it begins a new
  // session: when the main line's newest session did not close cleanly (its writer was killed),
  // that session keeps a copy of the main line's memory in rows of its own, as a side session
  // has, so that it can still be resumed once the new session continues the main line. Returns
  // the session kept, 0 for none. A file keeps none: its one writer resumes it before anything
  // else can begin.
  virtual std::int64_t keepUnfinishedMainLine() = 0;
  // From here on, the writer's memory (engine_state's writer keys, the kd-forest, the posterior,
  // the tiers and ages) is read and written in the rows of side session `session_id`: the
  // main-line tables are left to the main line; 0: the main line's again. kInvalidArgument on a
  // file.
  virtual void useSideMemory(std::int64_t session_id) = 0;
  // Reserves ids of `kind` in the open transaction (so a rolled-back frame gives them back):
  // at least `count` of them, all at or above `next` and above every id any writer used or
  // holds in a block.
  virtual IdBlock reserveIds(IdKind kind, std::int64_t count, std::int64_t next) = 0;
  // The newest location of every session, and the places of every other session than
  // `session_id` stored after those (a session's ids grow as it commits).
  virtual std::map<std::int64_t, std::int64_t> newestLocations() const = 0;
  virtual std::vector<SharedPlace> placesAfter(
      std::int64_t session_id, const std::map<std::int64_t, std::int64_t>& newest) const = 0;
};

}  // namespace placedb::storage
