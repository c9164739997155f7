// Opening a map: settings to component options, restoring RAM state from the file, sessions.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>

#include "features/cpu_support.h"
#include "features/feature_options.h"
#include "map/map_impl.h"
#include "map/map_structure.h"
#include "map/option_mapping.h"
#include "placedb/version.h"

namespace placedb {
namespace {

// The components check their own settings in their constructors; building them once before the
// map file is touched means a setting they refuse never creates or changes a file.
void checkComponentSettings(const Options& options) {
  auto extractor = makeFeatureExtractor(toFeatureOptions(options));
  vocab::Vocabulary vocabulary(toVocabularyOptions(options), extractor->dim(),
                               extractor->signature());
  BayesFilter filter(toFilterSettings(options));
  MemoryTiers tiers(toMemorySettings(options));
  simdLevel();  // PLACEDB_SIMD is a setting too (features/cpu_support.h)
}

}  // namespace

std::unique_ptr<Map> Map::open(const std::string& path, const Options& options, Mode mode) {
  options.validate();
  checkComponentSettings(options);
  return std::make_unique<MapImpl>(path, options, mode);
}

MapImpl::MapImpl(const std::string& path, const Options& options, Mode mode) : mode_(mode) {
  storage::OpenOptions open_options;
  open_options.side_writer = true;       // a server map may have other writers (map_fleet.cpp)
  open_options.check_references = true;  // a read-write open looks them up with its page check
  store_ = storage::openMapStore(
      path,
      mode == Mode::kLocalisation ? storage::OpenMode::kReadOnly : storage::OpenMode::kReadWrite,
      open_options);
  // Taken before the memory is read, so that what is read is the main line's as its writer
  // continues it; without it the memory is only the copy a side session would start from.
  main_memory_ = mode == Mode::kMapping && store_->claimMainLine();
  configure(options);
  restoreFromStore();
}

MapImpl::~MapImpl() {
  try {
    close();
  } catch (...) {
    // A destructor must not throw; the session simply stays marked as interrupted.
  }
}

void MapImpl::configure(const Options& options) {
  options.validate();
  options_ = options;
  extractor_ = makeFeatureExtractor(toFeatureOptions(options));
  if (auto made_with = store_->getStateText(kMapExtractorKey);
      made_with && *made_with != extractor_->signature())
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("{} was made with {} features; extractor={} gives {}: mixing them is "
                            "refused (use a new map)",
                            store_->path(), *made_with, toString(options.extractor),
                            extractor_->signature()));
  auto vocabulary_options = toVocabularyOptions(options);
  vocabulary_options.fixed = vocabulary_options.fixed || mode_ == Mode::kLocalisation ||
                             store_->getStateText(kVocabularyModeKey) == std::string("fixed");
  vocabulary_ = std::make_unique<vocab::Vocabulary>(vocabulary_options, extractor_->dim(),
                                                    extractor_->signature());
  filter_ = std::make_unique<BayesFilter>(toFilterSettings(options));
  tiers_ = std::make_unique<MemoryTiers>(toMemorySettings(options));
  index_ = InvertedIndex();
  graph_ = LinkGraph();
  vocabulary_state_ = VocabularyStateWriter();
}

void MapImpl::restoreFromStore() {
  const auto snapshot_of_file = store_->readSnapshot();
  // Every location holds its rows before any is read (storage/src/location_rows.h).
  store_->checkStoredRows();
  counters_ = EngineCounters();
  if (!counters_.load(*store_) && store_->lastFrame())
    throw Error(ErrorCode::kMapRefused,
                fmt::format("{} damaged: engine_state row '{}' is missing, and the map holds "
                            "frames; nothing was written",
                            store_->path(), kCountersKey));
  // Before the locations are listed: a place stored in between is found again, not missed.
  newest_known_.clear();
  if (store_->sharedByWriters()) newest_known_ = store_->newestLocations();

  // Tiers, with their ages in the transfer order (the location id on maps before schema 4).
  MemorySnapshot snapshot;
  snapshot.next_age = counters_.next_wm_age;
  const auto ages = store_->wmAges();
  std::int64_t last_wm_age = 0;
  for (const auto& [location, age] : ages) last_wm_age = std::max(last_wm_age, age);
  std::vector<std::int64_t> live;  // STM and WM
  for (Tier tier : {Tier::kStm, Tier::kWm, Tier::kLtm}) {
    for (const auto& row : store_->locationsInTier(tier)) {
      if (row.weight < 0)
        throw Error(ErrorCode::kMapRefused,
                    fmt::format("{}: locations row {} is damaged: weight {} is negative",
                                store_->path(), row.id, row.weight));
      const auto age = ages.find(row.id);
      std::int64_t entered = age == ages.end() ? row.id : age->second;
      // A location in LTM gets a new age when it comes back, so its own is never used; places
      // other writers stored have none in this writer's order (map_fleet.cpp).
      if (tier == Tier::kLtm) entered = std::min(entered, snapshot.next_age - 1);
      snapshot.locations.push_back({row.id, tier, row.weight, entered});
      if (tier == Tier::kStm) snapshot.stm.push_back(row.id);
      if (tier != Tier::kLtm) live.push_back(row.id);
    }
  }
  std::sort(snapshot.locations.begin(), snapshot.locations.end(),
            [](const auto& a, const auto& b) { return a.id < b.id; });
  std::sort(live.begin(), live.end());
  try {
    tiers_->restore(snapshot);
  } catch (const Error& e) {
    // The snapshot came from the file: if it does not fit, the file is damaged.
    if (e.code() != ErrorCode::kInvalidArgument) throw;
    throw Error(ErrorCode::kMapRefused,
                fmt::format("{} damaged: engine_state row '{}' and the locations and wm_entries "
                            "rows disagree ({}); nothing was written",
                            store_->path(), kCountersKey, e.what()));
  }

  // Signatures of STM and WM, and the words they reference.
  std::vector<std::int64_t> word_ids;
  {
    auto signatures = store_->loadWordIds(live);
    for (std::int64_t id : live) {
      word_ids.insert(word_ids.end(), signatures[id].begin(), signatures[id].end());
      index_.add(id, Signature::fromWords(std::move(signatures[id])));
    }
  }
  imported_words_ = store_->importedWordIds();
  word_ids.insert(word_ids.end(), imported_words_.begin(), imported_words_.end());
  std::sort(word_ids.begin(), word_ids.end());
  word_ids.erase(std::unique(word_ids.begin(), word_ids.end()), word_ids.end());
  auto state = vocabulary_state_.load(*store_);
  const std::optional<std::int64_t> next_word_id =
      state ? std::optional(state->next_word_id) : std::nullopt;
  if (state && state->kd_trees != options_.kd_trees)
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("{} indexes its words with kd_trees={}; kd_trees={} is refused "
                            "(the setting is fixed when a map is made)",
                            store_->path(), state->kd_trees, options_.kd_trees));
  if (state) {
    const int dim = extractor_->dim();
    auto load = [&](std::size_t begin, std::size_t count, float* rows, std::int64_t* created) {
      const std::vector<std::int64_t> span(word_ids.begin() + std::ptrdiff_t(begin),
                                           word_ids.begin() + std::ptrdiff_t(begin + count));
      store_->loadFloatDescriptors(span, dim, rows, created);
    };
    // On a fleet map this writer's working memory may hold words other writers created, with
    // ids past its own next one (map_fleet.cpp); elsewhere such a word means damage.
    const std::int64_t next_word_id = state->next_word_id;
    const bool shared_ids = store_->sharedByWriters() || counters_.word_block_end != 0;
    if (shared_ids && !word_ids.empty() && word_ids.back() >= next_word_id)
      state->next_word_id = word_ids.back() + 1;
    try {
      vocabulary_->restore(*state, word_ids, load);
      if (shared_ids) vocabulary_->continueAt(next_word_id);
    } catch (const Error& e) {
      // The state came from the file: if it does not fit, the file is damaged, not the caller.
      if (e.code() != ErrorCode::kInvalidArgument) throw;
      throw Error(ErrorCode::kMapRefused, store_->path() + ": " + e.what());
    }
  } else if (!word_ids.empty()) {
    throw Error(ErrorCode::kMapRefused,
                store_->path() + ": working memory has words but the vocabulary state is missing");
  }

  // Links among STM and WM locations.
  std::set<std::int64_t> live_set(live.begin(), live.end());
  for (std::int64_t id : live) {
    graph_.addNode(id);
    for (const auto& link : store_->links(id)) {
      std::int64_t other = link.location_a == id ? link.location_b : link.location_a;
      if (link.type != storage::LinkType::kMerge && live_set.count(other))
        graph_.addLink(id, other, linkKindOf(link.type));
    }
  }

  // Place codes of every tier, and the centres that made them.
  coder_.reset();
  places_.clear();
  places_.setThreads(resolveThreadCount(options_.threads));
  places_.setListsFrom(static_cast<std::size_t>(options_.place_lists_from));
  place_neighbourhood_.reset();  // of the codes just cleared
  ltm_words_.reset();            // their words went with the vocabulary configure() replaced
  auto centres = store_->getState(kPlaceCoderKey);
  if (!centres && !store_->placeCodes().empty())
    throw Error(ErrorCode::kMapRefused,
                fmt::format("{} damaged: engine_state row '{}' is missing, and the map holds "
                            "place codes made with it; nothing was written",
                            store_->path(), kPlaceCoderKey));
  if (centres) {
    try {
      coder_ = PlaceCoder::fromBytes(*centres, extractor_->dim());
      for (const auto& record : store_->placeCodes()) places_.add(record.location_id, record.code);
    } catch (const Error& e) {
      if (e.code() != ErrorCode::kInvalidArgument) throw;
      throw Error(ErrorCode::kMapRefused, store_->path() + ": " + e.what());
    }
  }

  FilterState filter_state;
  filter_state.posterior = store_->loadPosterior();
  for (const auto& [location, p] : filter_state.posterior)
    if (!std::isfinite(p) || p < 0 || p > 1 + 1e-9)
      throw Error(ErrorCode::kMapRefused,
                  fmt::format("{}: filter_posterior row of location {} is damaged: posterior {} "
                              "is not a probability",
                              store_->path(), location, p));
  // Before anything is written: the rows agree with each other (map/map_structure.h).
  checkStoredMemory(*store_,
                    {counters_, snapshot, last_wm_age, filter_state.posterior, next_word_id});
  filter_state.previous_score = counters_.previous_score;
  filter_->restore(filter_state);
}

void MapImpl::requireWritable(const char* what) const {
  if (mode_ == Mode::kLocalisation)
    throw Error(ErrorCode::kReadOnly,
                fmt::format("{}: {} needs the map opened for mapping, not localisation",
                            store_->path(), what));
  if (broken_)
    throw Error(ErrorCode::kStorage,
                fmt::format("{}: a previous frame failed to commit; reopen the map to resume",
                            store_->path()));
}

void MapImpl::requireSession(const char* what) const {
  requireWritable(what);
  if (!session_id_)
    throw Error(ErrorCode::kInternal, fmt::format("{}: {} before beginSession() or resumeSession()",
                                                  store_->path(), what));
}

SessionInfo MapImpl::toInfo(const storage::SessionRecord& record) const {
  SessionInfo info;
  info.id = record.id;
  info.source = record.source;
  info.started_at = record.started_at;
  info.ended_at = record.ended_at.value_or("");
  info.clean_close = record.clean_close;
  info.source_digest = record.source_digest.value_or("");
  info.frames = store_->frameCount(record.id);
  info.last_source_index = store_->lastFrameIndex(record.id);
  return info;
}

std::optional<SessionInfo> MapImpl::lastSession() const {
  auto last = store_->lastSession();
  if (!last) return std::nullopt;
  return toInfo(*last);
}

std::vector<SessionInfo> MapImpl::sessions() const {
  std::vector<SessionInfo> out;
  for (const auto& s : store_->sessions()) out.push_back(toInfo(s));
  return out;
}

std::map<std::string, std::string> MapImpl::sessionSettings(std::int64_t session_id) const {
  return store_->settings(session_id);
}

SessionInfo MapImpl::beginSession(const std::string& source, const std::string& source_digest) {
  requireWritable("beginSession");
  if (session_id_) close();
  closed_ = false;
  // Another writer continues the main line: this one starts from a copy (map_fleet.cpp).
  if (!store_->claimMainLine()) return beginSideSession(source, source_digest);
  if (!main_memory_) {
    configure(options_);
    restoreFromStore();
    main_memory_ = true;
  }
  auto tx = store_->begin();
  // A killed writer's session keeps the memory it had, for its writer to resume it later.
  if (const std::int64_t kept = store_->keepUnfinishedMainLine()) {
    // The main line goes on in the id blocks that session used: when it resumes, its own ids
    // come from new ones.
    EngineCounters own = counters_;
    own.frame_block_end = own.location_block_end = own.word_block_end = 0;
    store_->useSideMemory(kept);
    own.save(*store_);
    store_->useSideMemory(0);
  }
  std::int64_t id = store_->beginSession(source, options_.toSettings(), PLACEDB_VERSION_STRING);
  store_->claimSession(id);
  if (!source_digest.empty()) store_->setSourceDigest(id, source_digest);
  if (!store_->getStateText(kMapExtractorKey))
    store_->putState(kMapExtractorKey, extractor_->signature());
  startSessionMemory(id);
  counters_.save(*store_);
  tx.commit();
  session_id_ = id;
  return sessionInfo(id);
}

SessionInfo MapImpl::resumeSession(std::int64_t session_id) {
  requireWritable("resumeSession");
  if (session_id_) close();
  closed_ = false;
  const storage::SessionMemory memory = store_->sessionMemory(session_id);
  if (memory == storage::SessionMemory::kGone) {
    auto last = store_->lastSession();
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("{}: only the last session can be resumed (asked {}, last is {}; on "
                            "a map on a server, also a session of its own, begun while another "
                            "writer held the map)",
                            store_->path(), session_id, last ? last->id : 0));
  }
  // The session continues with the settings it started with, so its results stay exact.
  Options stored = Options::fromStoredSettings(store_->settings(session_id));
  if (memory == storage::SessionMemory::kMainLine) {
    if (!store_->claimMainLine())
      throw Error(ErrorCode::kMapBusy,
                  fmt::format("{} is busy: session {} continues the map's main line, which "
                              "another placedb writer holds",
                              store_->path(), session_id));
    store_->claimSession(session_id);
    if (!main_memory_ || stored.toSettings() != options_.toSettings()) {
      configure(stored);
      restoreFromStore();
      main_memory_ = true;
    }
  } else {
    // A side session of a fleet map: its own memory (a file refuses it here).
    store_->claimSession(session_id);
    store_->useSideMemory(session_id);
    store_->releaseMainLine();  // for another writer to continue
    main_memory_ = false;
    configure(stored);
    restoreFromStore();
  }
  store_->reopenSession(session_id);
  session_id_ = session_id;
  return sessionInfo(session_id);
}

void MapImpl::close() {
  read_ahead_.reset();
  if (closed_ || !session_id_ || broken_) {
    closed_ = true;
    return;
  }
  store_->endSession(*session_id_, true);
  store_->releaseSession(*session_id_);
  closed_ = true;
  session_id_.reset();
}

}  // namespace placedb

namespace placedb {

std::string MapImpl::checkConsistency() const {
  if (auto problem = tiers_->checkInvariants(); !problem.empty()) return problem;
  std::set<std::int64_t> live(tiers_->stm().begin(), tiers_->stm().end());
  for (std::int64_t id : tiers_->wm()) live.insert(id);
  if (index_.locationCount() != live.size())
    return fmt::format("inverted index holds {} locations, STM+WM {}", index_.locationCount(),
                       live.size());
  std::set<std::int64_t> words;
  for (std::int64_t id : live) {
    if (!index_.contains(id)) return fmt::format("location {} missing from the index", id);
    for (const auto& e : index_.signatureOf(id).entries()) words.insert(e.word);
  }
  words.insert(imported_words_.begin(), imported_words_.end());
  auto in_vocabulary = vocabulary_->ids();
  if (std::vector<std::int64_t>(words.begin(), words.end()) != in_vocabulary)
    return fmt::format("vocabulary holds {} words, STM+WM (and imports) reference {}",
                       in_vocabulary.size(), words.size());
  // The file agrees with RAM on every tier (this writer's own tiers, on a fleet map).
  std::map<std::int64_t, Tier> stored_tier;
  for (Tier tier : {Tier::kStm, Tier::kWm})
    for (const auto& row : store_->locationsInTier(tier)) stored_tier[row.id] = tier;
  for (std::int64_t id : live) {
    if (!store_->location(id)) return fmt::format("location {} is not in the file", id);
    const auto stored = stored_tier.find(id);
    if (stored == stored_tier.end() || stored->second != tiers_->tierOf(id))
      return fmt::format("location {} has another tier on file", id);
  }
  return {};
}

}  // namespace placedb
