// STM / WM / LTM bookkeeping: overflow, merging, transfer choice, retrieval and the tier invariant.
#include <gtest/gtest.h>

#include <random>

#include "memory/memory_tiers.h"
#include "placedb/error.h"

namespace placedb {
namespace {

MemorySettings smallStm(int stm_size) {
  MemorySettings s;
  s.stm_size = stm_size;
  s.immune_newest_ratio = 0.0;
  return s;
}

TEST(MemoryTiers, StmOverflowsOldestFirstIntoWm) {
  MemoryTiers m(smallStm(3));
  EXPECT_TRUE(m.push(1).empty());
  EXPECT_TRUE(m.push(2).empty());
  EXPECT_TRUE(m.push(3).empty());
  EXPECT_EQ(m.push(4), (std::vector<MemoryLocationId>{1}));
  EXPECT_EQ(m.tierOf(1), Tier::kWm);
  EXPECT_EQ(m.tierOf(4), Tier::kStm);
  EXPECT_EQ(m.stm(), (std::deque<MemoryLocationId>{2, 3, 4}));
  EXPECT_EQ(m.checkInvariants(), "");
  EXPECT_TRUE(m.isIn(1, Tier::kWm));
  EXPECT_FALSE(m.isIn(4, Tier::kWm));
  EXPECT_FALSE(m.isIn(99, Tier::kWm)) << "an unknown location is in no tier, not an error";
  EXPECT_THROW(m.push(4), Error);

  MemoryTiers no_stm(smallStm(0));  // every location goes straight to WM
  EXPECT_EQ(no_stm.push(9), (std::vector<MemoryLocationId>{9}));
}

TEST(MemoryTiers, MergeRaisesWeightAndRemovesTheAbsorbedLocation) {
  MemoryTiers m(smallStm(2));
  m.push(1);
  m.push(2);
  // 3 absorbs 2 (paper 004: the new image stays with the old weight + 1); counted after the merge,
  // STM holds 1 and 3, so nothing overflows.
  EXPECT_TRUE(m.push(3, 2).empty());
  EXPECT_FALSE(m.contains(2));
  EXPECT_EQ(m.weightOf(3), 1);
  EXPECT_TRUE(m.push(4, 3).empty());
  EXPECT_EQ(m.weightOf(4), 2);
  EXPECT_EQ(m.push(5), (std::vector<MemoryLocationId>{1}));
  // Keeping the older id instead: 4 absorbs 5 -> 2 + 0 + 1.
  m.merge(4, 5);
  EXPECT_EQ(m.weightOf(4), 3);
  // A WM location's weight change re-ranks it for transfer.
  m.addWeight(1, 5);
  EXPECT_EQ(m.weightOf(1), 5);
  EXPECT_EQ(m.checkInvariants(), "");
}

// WM ids 1..8 after pushes through an STM of size 0; weights set per id.
MemoryTiers wmWithWeights(const std::map<MemoryLocationId, std::int64_t>& weights,
                          MemorySettings settings) {
  settings.stm_size = 0;
  MemoryTiers m(settings);
  for (const auto& [id, weight] : weights) {
    m.push(id);
    m.addWeight(id, weight);
  }
  return m;
}

TEST(MemoryTiers, TransfersLowestWeightThenOldestAndRespectsImmunity) {
  MemorySettings s;
  s.immune_newest_ratio = 0.0;
  const std::map<MemoryLocationId, std::int64_t> weights{{1, 2}, {2, 0}, {3, 1}, {4, 0},
                                                         {5, 0}, {6, 3}, {7, 1}, {8, 0}};
  MemoryTiers m = wmWithWeights(weights, s);
  // Weight 0: 2, 4, 5, 8 (ages ascend with id), then weight 1: 3, 7, then 1, then 6.
  EXPECT_EQ(m.transferCandidates(100, {}), (std::vector<MemoryLocationId>{2, 4, 5, 8, 3, 7, 1, 6}));
  EXPECT_EQ(m.transferCandidates(3, {}), (std::vector<MemoryLocationId>{2, 4, 5}));
  // The hypothesis (4) and its neighbours (3, 5) are immune.
  EXPECT_EQ(m.transferCandidates(3, {3, 4, 5}), (std::vector<MemoryLocationId>{2, 8, 7}));

  // Newest part: the 2 most recently created WM locations (7, 8) are immune.
  s.immune_newest_count = 2;
  MemoryTiers newest = wmWithWeights(weights, s);
  EXPECT_EQ(newest.newestWm(), (std::set<MemoryLocationId>{7, 8}));
  EXPECT_EQ(newest.transferCandidates(100, {}), (std::vector<MemoryLocationId>{2, 4, 5, 3, 1, 6}));
  // Ratio form: floor(0.5 x 8) = 4 newest (5..8) immune.
  s.immune_newest_count = 0;
  s.immune_newest_ratio = 0.5;
  EXPECT_EQ(wmWithWeights(weights, s).transferCandidates(100, {}),
            (std::vector<MemoryLocationId>{2, 4, 3, 1}));

  // Transferred locations go to LTM; retrieved ones are immune for the rest of their frame, and
  // after it rank as the newest to enter WM (2 goes after 5 and 8 of the same weight).
  m.transferToLtm({2, 4});
  EXPECT_EQ(m.tierOf(2), Tier::kLtm);
  EXPECT_EQ(m.ltm(), (std::vector<MemoryLocationId>{2, 4}));
  m.beginFrame();
  m.retrieveToWm({2});
  EXPECT_EQ(m.tierOf(2), Tier::kWm);
  EXPECT_EQ(m.transferCandidates(2, {}), (std::vector<MemoryLocationId>{5, 8}));
  const std::int64_t age_before = m.ageOf(8);
  m.beginFrame();
  EXPECT_GT(m.ageOf(2), age_before);
  EXPECT_EQ(m.transferCandidates(2, {}), (std::vector<MemoryLocationId>{5, 8}));
  EXPECT_EQ(m.transferCandidates(3, {}), (std::vector<MemoryLocationId>{5, 8, 2}));
  EXPECT_THROW(m.transferToLtm({4}), Error);  // already in LTM
  const MemorySnapshot before = m.snapshot();
  EXPECT_THROW(m.transferToLtm({5, 5}), Error);  // refused whole: 5 stays in WM
  EXPECT_THROW(m.retrieveToWm({4, 4}), Error);
  EXPECT_EQ(m.snapshot(), before);
  EXPECT_EQ(m.checkInvariants(), "");
}

// 14 locations through an STM of size 0, so all in WM.
MemoryTiers fourteenInWm(const MemorySettings& s) {
  MemoryTiers m(s);
  for (MemoryLocationId id = 0; id < 14; ++id) m.push(id);
  return m;
}

TEST(MemoryTiers, PlannedTransfersFollowSizeAndTimeTriggers) {
  MemorySettings s;
  s.time_floor = 0;
  s.stm_size = 0;
  s.wm_max = 10;
  s.time_limit_s = 0.7;
  MemoryTiers m = fourteenInWm(s);
  EXPECT_EQ(m.plannedTransfers(0.1), 4u);  // 14 - 10, time fine
  // 1.4 s against 0.7 s: half the time is excess, so ceil(14 x 0.5) = 7 (> 4).
  EXPECT_EQ(m.plannedTransfers(1.4), 7u);
  // Barely over the limit still moves at least one.
  s.wm_max = 0;
  MemoryTiers timed = fourteenInWm(s);
  EXPECT_EQ(timed.plannedTransfers(0.7001), 1u);
  EXPECT_EQ(timed.plannedTransfers(0.7), 0u);
  s.max_transfers_per_frame = 3;
  MemoryTiers capped = fourteenInWm(s);
  EXPECT_EQ(capped.plannedTransfers(1.4), 3u);
  // The time trigger never takes WM below its floor; the size trigger is not bound by it.
  s.max_transfers_per_frame = 0;
  s.time_floor = 12;
  MemoryTiers floored = fourteenInWm(s);
  EXPECT_EQ(floored.plannedTransfers(1.4), 2u);
  s.time_floor = 20;
  MemoryTiers under = fourteenInWm(s);
  EXPECT_EQ(under.plannedTransfers(10.0), 0u);
  s.wm_max = 10;
  MemoryTiers sized = fourteenInWm(s);
  EXPECT_EQ(sized.plannedTransfers(10.0), 4u);
}

TEST(MemoryTiers, RetrievalCandidatesAreLtmNeighboursUpToTheCap) {
  MemorySettings s = smallStm(0);
  s.max_retrieved = 2;
  MemoryTiers m(s);
  for (MemoryLocationId id = 1; id <= 6; ++id) m.push(id);
  m.transferToLtm({2, 3, 5});
  // 4 is in WM, 9 is unknown, 3 repeats: only LTM ones, in the caller's order, at most 2.
  EXPECT_EQ(m.retrievalCandidates(1, {4, 3, 9, 3, 5, 2}), (std::vector<MemoryLocationId>{3, 5}));
  EXPECT_TRUE(m.retrievalCandidates(-1, {3, 5}).empty());  // no hypothesis
  EXPECT_EQ(m.retrievalCandidates(1, {4, 3, 9, 3, 5, 2}, 3),
            (std::vector<MemoryLocationId>{3, 5, 2}));
  EXPECT_EQ(parseTier(toString(Tier::kLtm)), Tier::kLtm);
  EXPECT_THROW(parseTier("dram"), Error);
  EXPECT_THROW(m.retrieveToWm({4}), Error);
}

TEST(MemoryTiers, RandomHistoryKeepsEveryLocationInExactlyOneTier) {
  std::mt19937_64 rng(99);
  std::uniform_int_distribution<int> action(0, 9);
  MemorySettings s;
  s.stm_size = 5;
  s.wm_max = 40;
  s.immune_newest_ratio = 0.1;
  s.max_retrieved = 3;
  MemoryTiers m(s);
  MemoryLocationId next_id = 0;
  std::size_t created = 0, merged = 0;
  for (int frame = 0; frame < 3000; ++frame) {
    m.beginFrame();
    const int a = action(rng);
    if (a < 3 && !m.stm().empty()) {
      m.push(next_id++, m.stm().back());  // similar to the previous image: merge
      ++created;
      ++merged;
    } else {
      m.push(next_id++);
      ++created;
    }
    if (a == 4 && m.ltmSize() > 0) {
      const auto ltm = m.ltm();
      std::vector<MemoryLocationId> asked;
      for (int k = 0; k < 5; ++k) asked.push_back(ltm[rng() % ltm.size()]);
      const auto wm = m.wm();
      const MemoryLocationId best = wm.empty() ? -1 : wm[rng() % wm.size()];
      const auto chosen = m.retrievalCandidates(best, asked);
      EXPECT_LE(chosen.size(), 3u);
      m.retrieveToWm(chosen);
    }
    if (a == 5 && m.wmSize() > 0) m.addWeight(m.wm()[rng() % m.wmSize()], 1);
    std::set<MemoryLocationId> immune;
    if (m.wmSize() > 2) immune = {m.wm()[rng() % m.wmSize()]};
    const std::size_t planned = m.plannedTransfers(a == 6 ? 1.0 : 0.1);
    const auto chosen = m.transferCandidates(planned, immune);
    for (MemoryLocationId id : chosen) {
      EXPECT_EQ(immune.count(id), 0u);
      EXPECT_EQ(m.retrievedThisFrame().count(id), 0u);
    }
    m.transferToLtm(chosen);
    ASSERT_EQ(m.checkInvariants(), "") << "frame " << frame;
    ASSERT_EQ(m.stm().size() + m.wmSize() + m.ltmSize(), created - merged) << frame;
    // wm() is kept as locations come and go, not derived when asked: it must still be every
    // location whose record says WM, by id.
    std::vector<MemoryLocationId> in_wm;
    for (const LocationRecord& r : m.snapshot().locations)
      if (r.tier == Tier::kWm) in_wm.push_back(r.id);
    ASSERT_EQ(m.wm(), in_wm) << "frame " << frame;
    if (frame % 500 == 0) {
      MemoryTiers copy(s);
      copy.restore(m.snapshot());
      EXPECT_EQ(copy.snapshot(), m.snapshot());
    }
  }
  EXPECT_GT(m.ltmSize(), 0u);
  EXPECT_LE(m.wmSize(), 40u + 3u);  // the size trigger holds WM near wm_max
}

TEST(MemoryTiers, InvariantCheckCatchesACorruptSnapshot) {
  MemoryTiers m(smallStm(2));
  for (MemoryLocationId id = 0; id < 5; ++id) m.push(id);
  MemorySnapshot snap = m.snapshot();
  snap.stm.push_back(0);  // 0 is a WM record: listed in two tiers
  MemoryTiers other(smallStm(2));
  EXPECT_THROW(other.restore(snap), Error);
  snap = m.snapshot();
  snap.stm.pop_back();  // an STM record in no tier
  EXPECT_THROW(other.restore(snap), Error);
  EXPECT_EQ(other.snapshot(),
            MemoryTiers(smallStm(2)).snapshot());  // failed restores change nothing
}

TEST(MemorySettings, ValidateNamesBadFields) {
  MemorySettings s;
  s.stm_size = -1;
  s.immune_newest_ratio = 1.0;
  try {
    s.validate();
    FAIL() << "bad settings accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find("stm_size"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("immune_newest_ratio"), std::string::npos);
  }
}

}  // namespace
}  // namespace placedb
