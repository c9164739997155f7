#pragma once
// PgMapStore: a placedb map in a PostgreSQL database, named by a libpq connection URI
// (postgresql://... or postgres://...). The same tables and views as the SQLite map
// (migrations/pg/), and the same rules (storage/include/placedb/storage/map_store.h), with:
//
// - writers: a read-write open takes the main line's advisory lock kWriterLockKey for the
//   connection's life (pg_try_advisory_lock); when another writer holds it, a second writer gets
//   kMapBusy, or, with OpenOptions::side_writer, opens for a side session of its own
//   (pg_map_store_fleet.cpp). A read-only open takes no lock and runs every transaction
//   read-only.
// - every statement prepared once per connection, parameters and results in binary, and one
//   statement per method whatever the number of rows (arrays through unnest, = ANY): a frame's
//   writes are a fixed number of round trips in one transaction.
// - ids the database assigns (frames with id 0, sessions, vocabulary imports) are max(id) + 1,
//   as SQLite's rowids, so a single writer numbers rows exactly as a file does; the engine's own
//   ids come from blocks it reserves (reserveIds).
#include <memory>
#include <set>
#include <string>

#include "placedb/storage/map_store.h"
#include "postgres/pg_connection.h"

namespace placedb::storage {

// The advisory lock the main line's writer holds: 'PLDB', the application id of every placedb
// map. A writer of a side session holds its session's lock only (pg_map_store_fleet.cpp).
inline constexpr std::int64_t kWriterLockKey = 0x504C4442;
// Every writer's lock on its session: (kSessionLockClass, session id), in the two-key space.
inline constexpr std::int64_t kSessionLockClass = 0x504C4453;  // 'PLDS'
// Transaction locks: one session is created at a time (ids are max + 1), one migration runs.
inline constexpr std::int64_t kSessionsKey = 0x504C4443;   // 'PLDC'
inline constexpr std::int64_t kMigrationKey = 0x504C444D;  // 'PLDM'

class PgMapStore final : public MapStore {
 public:
  PgMapStore(const std::string& uri, OpenMode mode, const OpenOptions& options = {});
  ~PgMapStore() override;

  const std::string& path() const override { return label_; }
  bool readOnly() const override { return read_only_; }
  int schemaVersion() const override;

  // One per processed frame: everything written for the frame commits together.
  Transaction begin() override;
  // For loading many rows at once (restoring memory on open), also on a read-only map.
  ReadSnapshot readSnapshot() const override;

  // Sessions.
  std::int64_t beginSession(const std::string& source,
                            const std::map<std::string, std::string>& settings,
                            const std::string& software_version) override;
  void setSourceDigest(std::int64_t session_id, const std::string& digest) override;
  void endSession(std::int64_t session_id, bool clean) override;
  // Marks an ended session as running again (a resumed session): ended_at NULL, not clean.
  void reopenSession(std::int64_t session_id) override;
  std::vector<SessionRecord> sessions() const override;
  std::optional<SessionRecord> lastSession() const override;
  std::map<std::string, std::string> settings(std::int64_t session_id) const override;

  // Frames. A record with id 0 gets the next id from the database; a non-zero id is kept.
  // Within a transaction frames, words, locations and hypotheses may reference each other in
  // any insertion order: those foreign keys are checked at commit.
  std::int64_t insertFrame(const FrameRecord& frame) override;
  std::optional<FrameRecord> frame(std::int64_t frame_id) const override;
  std::vector<FrameRecord> frames(std::int64_t session_id) const override;  // by source index
  std::optional<std::int64_t> lastFrameIndex(std::int64_t session_id) const override;
  std::int64_t frameCount() const override;
  std::int64_t frameCount(std::int64_t session_id) const override;
  std::int64_t frameCount(FrameOutcome outcome) const override;
  std::optional<FrameRecord> lastFrame() const override;  // the newest, over all sessions

  // Locations.
  void insertLocation(const LocationRecord& location) override;
  void updateWeight(std::int64_t location_id, std::int64_t weight) override;
  void setTier(const std::vector<std::int64_t>& location_ids, Tier tier) override;
  // Removes the location with its references, coverage and links (frames keep NULL).
  void deleteLocation(std::int64_t location_id) override;
  void addCoveredFrame(std::int64_t location_id, std::int64_t frame_id) override;
  std::vector<std::int64_t> coveredFrames(std::int64_t location_id) const override;
  std::map<std::int64_t, std::vector<std::int64_t>> coveredFrames(
      const std::vector<std::int64_t>& location_ids) const override;
  std::vector<LocationWeight> locationsInTier(Tier tier) const override;  // by id
  std::optional<LocationRecord> location(std::int64_t location_id) const override;
  std::int64_t locationCount() const override;

  // Words.
  void insertWords(const std::vector<WordRecord>& words) override;
  // The words found, in the order asked; unknown ids are skipped.
  std::vector<WordRecord> loadWords(const std::vector<std::int64_t>& word_ids) const override;
  // Bulk form for loading an index: word_ids[i]'s float32 descriptor of `dim` values goes to row
  // i of `rows` (word_ids.size() x dim, contiguous) and its creating frame (or -1) to
  // created[i]. A word that is missing, or of another type or dimension, is kMapRefused.
  void loadFloatDescriptors(const std::vector<std::int64_t>& word_ids, int dim, float* rows,
                            std::int64_t* created) const override;
  void putLocationWordDescriptors(const LocationWordDescriptors& words) override;
  std::vector<LocationWordDescriptors> locationWordDescriptors(
      const std::vector<std::int64_t>& location_ids) const override;
  std::int64_t wordCount() const override;
  std::optional<std::int64_t> maxWordId() const override;
  // Words of imported vocabularies, ascending: they stay in the index whatever the tiers do.
  std::vector<std::int64_t> importedWordIds() const override;

  // Word references: a location's signature, kept in insertion order.
  void insertWordRefs(std::int64_t location_id, const std::vector<WordRef>& refs) override;
  void replaceWordRefs(std::int64_t location_id, const std::vector<WordRef>& refs) override;
  std::vector<WordRef> loadWordRefs(std::int64_t location_id) const override;
  std::map<std::int64_t, std::vector<WordRef>> loadWordRefs(
      const std::vector<std::int64_t>& location_ids) const override;
  // Only the word ids of each location's references, in order: a signature without keypoints.
  std::map<std::int64_t, std::vector<std::int64_t>> loadWordIds(
      const std::vector<std::int64_t>& location_ids) const override;
  std::vector<std::int64_t> wordsOfLocations(
      const std::vector<std::int64_t>& location_ids) const override;
  // The inverted index: locations whose signature holds the word, ascending.
  std::vector<std::int64_t> locationsOfWord(std::int64_t word_id) const override;

  // Links, stored once per unordered pair and type; inserting again updates the score.
  void insertLink(std::int64_t a, std::int64_t b, LinkType type,
                  std::optional<double> score) override;
  std::vector<LinkRecord> links(std::int64_t location_id) const override;
  // Every link of one type, by (location_a, location_b).
  std::vector<LinkRecord> linksOfType(LinkType type) const override;
  std::int64_t linkCount(LinkType type) const override;
  // Frames whose loop-closure hypothesis was accepted (several frames merged into one location
  // that close on one place make one loop-closure link); `posed`: only those with a pose.
  std::int64_t acceptedClosureCount(bool posed = false) const override;
  // Locations linked to `location_id` (by `type`, or any link) that sit in `tier`, ascending.
  std::vector<std::int64_t> linkedInTier(
      std::int64_t location_id, Tier tier,
      std::optional<LinkType> type = std::nullopt) const override;

  // Loop-closure hypotheses, one per frame.
  void insertHypothesis(const HypothesisRecord& hypothesis) override;
  std::optional<HypothesisRecord> hypothesis(std::int64_t frame_id) const override;
  // Every accepted hypothesis that carries a pose (schema 7), by frame id.
  std::vector<ClosurePoseRecord> closurePoses() const override;

  // Engine state for an exact resume.
  void putState(const std::string& key, const std::vector<std::uint8_t>& value) override;
  void putState(const std::string& key, const std::string& value) override;
  std::optional<std::vector<std::uint8_t>> getState(const std::string& key) const override;
  std::optional<std::string> getStateText(const std::string& key) const override;
  void deleteState(const std::string& key) override;
  // The vocabulary's kd-forest: upserts and deletes nodes by (tree, node); with replace_all the
  // table is emptied first. loadKdNodes() returns every node, by tree and node.
  void writeKdNodes(const std::vector<KdNodeRecord>& upserts,
                    const std::vector<std::pair<int, std::int64_t>>& deletions,
                    bool replace_all) override;
  std::vector<KdNodeRecord> loadKdNodes() const override;
  // Replaces the whole stored posterior.
  void putPosterior(const std::vector<std::pair<std::int64_t, double>>& posterior) override;
  std::vector<std::pair<std::int64_t, double>> loadPosterior() const override;  // by location id

  // Memory tiers (schema 4). Every location's place code, whatever its tier; and its age in the
  // transfer order (the order of entering STM/WM; a location brought back from LTM enters again).
  void putPlaceCode(std::int64_t location_id, const std::vector<std::int8_t>& code) override;
  std::vector<PlaceCodeRecord> placeCodes() const override;  // by location id
  std::optional<std::vector<std::int8_t>> placeCode(std::int64_t location_id) const override;
  void setWmAges(const std::vector<std::pair<std::int64_t, std::int64_t>>& ages) override;
  void checkStoredRows() const override;
  // Every location's age; its id where none was stored (maps made before schema 4).
  std::map<std::int64_t, std::int64_t> wmAges() const override;

  // Vocabulary imports. imported_at is set to now when empty.
  std::int64_t recordVocabularyImport(const VocabularyImportRecord& import) override;
  std::vector<VocabularyImportRecord> vocabularyImports() const override;

  void readTable(const TableColumns& t,
                 const std::function<void(const TableRow&)>& row) const override;
  void writeRows(const TableColumns& t, const std::vector<TableRow>& rows) override;

  // Writers (map_store.h; several at once: storage/src/postgres/pg_map_store_fleet.cpp).
  bool sharedByWriters() const override;
  bool claimMainLine() override;
  void releaseMainLine() override;
  SessionMemory sessionMemory(std::int64_t session_id) const override;
  void claimSession(std::int64_t session_id) override;
  void releaseSession(std::int64_t session_id) override;
  std::int64_t keepUnfinishedMainLine() override;
  std::int64_t beginSideSession(const std::string& source,
                                const std::map<std::string, std::string>& settings,
                                const std::string& software_version) override;
  void useSideMemory(std::int64_t session_id) override;
  IdBlock reserveIds(IdKind kind, std::int64_t count, std::int64_t next) override;
  std::map<std::int64_t, std::int64_t> newestLocations() const override;
  std::vector<SharedPlace> placesAfter(
      std::int64_t session_id, const std::map<std::int64_t, std::int64_t>& newest) const override;

 private:
  void requireWritable() const;
  // Sets (or clears) one of a location's held bits (location_rows.h), pipelined.
  void markHeld(std::int64_t location_id, std::int64_t bit, bool held);
  // Refuses the map unless every location of `refs` (rows by location) matches its refs_digest.
  void requireRefsDigests(const std::map<std::int64_t, std::vector<WordRef>>& refs) const;
  // Fills held, refs_digest and the new sums of a map upgraded to schema 15.
  void fillLocationRows();
  void refuseGuardsOfMissingRole();
  // Locations this store inserted and wrote no reference of yet: their first references need no
  // read of earlier ones for the digest.
  std::set<std::int64_t> fresh_locations_;
  detail::WriteScope writeScope();
  std::int64_t storedKdNodeRows() const;
  void migrate();

  // The main line's memory, in one snapshot, into the own rows of `session_id`.
  void copyMainLineMemory(std::int64_t session_id);
  // A side session's own memory (pg_map_store_fleet.cpp), used instead of the main line's
  // tables when side_session_ is set.
  void sidePutState(const std::string& key, const void* data, std::size_t size);
  std::optional<std::vector<std::uint8_t>> sideGetState(const std::string& key) const;
  void sideDeleteState(const std::string& key);
  std::vector<KdNodeRecord> sideLoadKdNodes() const;
  void sidePutPosterior(const std::vector<std::int64_t>& ids,
                        const std::vector<double>& probabilities);
  std::vector<std::pair<std::int64_t, double>> sideLoadPosterior() const;
  void sideInsertLocation(const LocationRecord& location);
  void sideSetTier(const std::vector<std::int64_t>& ids, Tier tier);
  std::vector<LocationWeight> sideLocationsInTier(Tier tier) const;
  void sideSetWmAges(const std::vector<std::int64_t>& ids, const std::vector<std::int64_t>& ages);
  std::map<std::int64_t, std::int64_t> sideWmAges() const;
  std::vector<std::int64_t> sideLinkedInTier(std::int64_t location_id, Tier tier,
                                             std::optional<LinkType> type) const;
  // A key of engine_state that this writer keeps in its side session's rows.
  bool sideKey(const std::string& key) const { return side_session_ && isWriterStateKey(key); }

  std::string label_;  // the URI without its password
  bool read_only_;
  std::unique_ptr<detail::PgConnection> db_;
  bool main_line_ = false;          // holds kWriterLockKey
  std::int64_t side_session_ = 0;   // whose own memory this writer uses; 0: the main line's
  std::set<std::int64_t> claimed_;  // sessions whose lock this writer holds
};

}  // namespace placedb::storage
