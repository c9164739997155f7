// Fleet maps: several writers of one map on a PostgreSQL server at once, each in its own session
// (schema/SCHEMA.md, "Fleet maps"; storage/src/postgres/pg_map_store_fleet.cpp keeps the rows).
//
// - The main line. One writer at a time continues the memory in the map-wide tables, exactly as
//   the writer of a file does: a lone writer on a server decides as on a file. A writer that
//   begins while another holds the main line starts a side session, whose memory (tiers, filter,
//   vocabulary index, counters) is a copy of the main line's kept in rows of its own.
// - Ids. Frames, locations and words get ids from blocks each writer reserves in the frame's
//   transaction; a lone writer's blocks follow each other, so its ids are a file's.
// - Other writers' places. Before each frame a writer adds the places the others stored since
//   its last look to its long-term memory, with their place codes: the LTM search brings them
//   back to working memory when a frame looks like them, retrieval follows links to them, and
//   their words come with them. Each writer grows its own words from its own blocks; a place
//   another writer stored is recognised through its place code and the geometric check, and its
//   words join this writer's vocabulary when it comes back (SCHEMA.md says what that means for
//   determinism).
#include <fmt/format.h>

#include <algorithm>

#include "map/map_impl.h"
#include "map/map_structure.h"
#include "placedb/version.h"

namespace placedb {
namespace {

// Ids a writer reserves at a time. A frame takes one frame id, at most one location id and at
// most one word id per feature; a block of words lasts a few hundred frames of lip6_outdoor.
constexpr std::int64_t kFrameBlock = 1024;
constexpr std::int64_t kLocationBlock = 1024;
constexpr std::int64_t kWordBlock = 65536;

}  // namespace

void MapImpl::reserveIds(std::int64_t words) {
  const bool shared = store_->sharedByWriters();
  // A file's writer needs no block, unless a copy of a fleet map left it one to finish.
  const auto shortOf = [shared](std::int64_t next, std::int64_t end, std::int64_t count) {
    return end == 0 ? shared : next + count > end;
  };
  // The block continues the one before when no other writer reserved in between (always, for a
  // lone writer); else the rest of the old one is left unused and the ids jump. Returns the
  // jump.
  const auto reserve = [this](storage::IdKind kind, std::int64_t count, std::int64_t block,
                              std::int64_t& next, std::int64_t& end) {
    if (!frame_tx_) frame_tx_.emplace(store_->begin());
    const std::int64_t from = end != 0 ? end : next;
    const storage::IdBlock b = store_->reserveIds(kind, std::max(count, block), from);
    std::int64_t jump = 0;
    if (b.first != from) {
      jump = b.first - next;
      next = b.first;
    }
    end = b.end;
    return jump;
  };
  if (shortOf(counters_.next_frame_id, counters_.frame_block_end, 1))
    counters_.frame_clock_shift += reserve(storage::IdKind::kFrame, 1, kFrameBlock,
                                           counters_.next_frame_id, counters_.frame_block_end);
  if (shortOf(counters_.next_location_id, counters_.location_block_end, 1))
    reserve(storage::IdKind::kLocation, 1, kLocationBlock, counters_.next_location_id,
            counters_.location_block_end);
  if (words > 0 && shortOf(vocabulary_->nextWordId(), counters_.word_block_end, words)) {
    std::int64_t next = vocabulary_->nextWordId();
    reserve(storage::IdKind::kWord, words, kWordBlock, next, counters_.word_block_end);
    vocabulary_->continueAt(next);
  }
}

void MapImpl::keepWordIdsInBlock(std::int64_t next_word_id) {
  if (counters_.word_block_end != 0 && vocabulary_->nextWordId() != next_word_id)
    vocabulary_->continueAt(next_word_id);
}

void MapImpl::learnOtherWritersPlaces() {
  if (!store_->sharedByWriters() || !session_id_) return;
  for (storage::SharedPlace& place : store_->placesAfter(*session_id_, newest_known_)) {
    std::int64_t& newest = newest_known_[place.session_id];
    newest = std::max(newest, place.location_id);
    if (tiers_->contains(place.location_id)) continue;  // known since this writer's restore
    tiers_->addToLtm(place.location_id, place.weight);
    if (coder_ && !place.code.empty()) places_.add(place.location_id, place.code);
  }
}

void MapImpl::startSessionMemory(std::int64_t session_id) {
  // A new session's locations never merge with, nor link to, the previous session's newest one;
  // the previous session's STM becomes loop candidates.
  std::vector<std::int64_t> stm(tiers_->stm().begin(), tiers_->stm().end());
  if (!stm.empty()) {
    MemorySnapshot snap = tiers_->snapshot();
    for (auto& r : snap.locations)
      if (r.tier == Tier::kStm) r.tier = Tier::kWm;
    snap.stm.clear();
    tiers_->restore(snap);
    store_->setTier(stm, storage::Tier::kWm);
  }
  counters_.last_location = 0;
  counters_.last_session = session_id;
  counters_.tiers_digest = tiersDigest({tiers_->stm().begin(), tiers_->stm().end()}, tiers_->wm());
}

SessionInfo MapImpl::beginSideSession(const std::string& source, const std::string& source_digest) {
  // The place codes' centres come from the main line's first location: a side session that
  // trained its own would make codes no other writer could compare.
  if (!store_->getState(kPlaceCoderKey))
    throw Error(ErrorCode::kMapBusy,
                fmt::format("{} is busy: another writer holds its main line and has not stored "
                            "a place yet; start other writers once it has mapped a frame",
                            store_->path()));
  try {
    auto tx = store_->begin();
    const std::int64_t id =
        store_->beginSideSession(source, options_.toSettings(), PLACEDB_VERSION_STRING);
    if (!source_digest.empty()) store_->setSourceDigest(id, source_digest);
    main_memory_ = false;
    // RAM becomes the copy the store just took, read in the same transaction.
    configure(options_);
    restoreFromStore();
    startSessionMemory(id);
    // The main line's blocks stay the main line's: this session reserves its own.
    counters_.frame_block_end = counters_.location_block_end = counters_.word_block_end = 0;
    // Another robot's camera: the main line's feature counts say nothing of what a bad frame of
    // this one is (rtabmap_samples after lip6_outdoor's mean would lose 4 of its 43 closures).
    counters_.feature_sum = counters_.feature_frames = 0;
    counters_.save(*store_);
    tx.commit();
    session_id_ = id;
    return sessionInfo(id);
  } catch (...) {
    broken_ = true;  // RAM and the store's memory belong to a session that was rolled back
    throw;
  }
}

SessionInfo MapImpl::sessionInfo(std::int64_t session_id) const {
  for (const auto& record : store_->sessions())
    if (record.id == session_id) return toInfo(record);
  throw Error(ErrorCode::kInternal,
              fmt::format("{}: session {} vanished", store_->path(), session_id));
}

}  // namespace placedb
