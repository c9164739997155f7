// Signatures, eq. 5 similarity, and the inverted index checked against brute force.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>

#include "filter/inverted_index.h"
#include "filter/signature.h"
#include "placedb/error.h"

namespace placedb {
namespace {

TEST(Signature, CountsMultiplicityAndSortsWords) {
  const Signature s = Signature::fromWords({7, 3, 7, 7, 1});
  ASSERT_EQ(s.entries().size(), 3u);
  EXPECT_EQ(s.entries()[0].word, 1);
  EXPECT_EQ(s.entries()[1].word, 3);
  EXPECT_EQ(s.entries()[2].word, 7);
  EXPECT_EQ(s.countOf(7), 3);
  EXPECT_EQ(s.countOf(4), 0);
  EXPECT_EQ(s.featureCount(), 5);
  EXPECT_EQ(Signature::fromCounts({{7, 2}, {1, 1}, {3, 1}, {7, 1}}), s);
}

TEST(Signature, RejectsNonPositiveCounts) {
  try {
    Signature::fromCounts({{1, 0}});
    FAIL() << "a zero count was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
  }
}

TEST(Similarity, PairsMinimumMultiplicityOverLargerBag) {
  // A: word 1 x3, word 2 x1, word 3 x1 (|A| = 5). B: word 1 x2, word 2 x2, word 4 x1 (|B| = 5).
  // Pairs: word 1 min(3,2) = 2, word 2 min(1,2) = 1 -> N_pair = 3, sim = 3/5.
  const Signature a = Signature::fromWords({1, 1, 1, 2, 3});
  const Signature b = Signature::fromWords({1, 1, 2, 2, 4});
  EXPECT_EQ(pairedFeatures(a, b), 3);
  EXPECT_DOUBLE_EQ(similarity(a, b), 0.6);
  EXPECT_DOUBLE_EQ(similarity(b, a), 0.6);
  // C: word 1 x1 (|C| = 1): one pair over max(5, 1) = 5.
  const Signature c = Signature::fromWords({1});
  EXPECT_DOUBLE_EQ(similarity(a, c), 0.2);
  // D: word 1 x6, word 2 x2 (|D| = 8) with A: min(3,6) + min(1,2) = 4 over 8.
  const Signature d = Signature::fromWords({1, 1, 1, 1, 1, 1, 2, 2});
  EXPECT_DOUBLE_EQ(similarity(a, d), 0.5);
  EXPECT_DOUBLE_EQ(similarity(a, a), 1.0);
}

TEST(Similarity, EmptyBagsGiveZero) {
  const Signature empty;
  const Signature a = Signature::fromWords({1, 2});
  EXPECT_EQ(similarity(empty, a), 0.0);
  EXPECT_EQ(similarity(a, empty), 0.0);
  EXPECT_EQ(similarity(empty, empty), 0.0);
  EXPECT_EQ(similarity(a, Signature::fromWords({3, 4})), 0.0);
}

Signature randomSignature(std::mt19937_64& rng, int vocabulary) {
  std::uniform_int_distribution<int> size(0, 60);
  // Squaring skews draws towards small ids, so some words are shared widely and repeat inside a
  // bag.
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<WordId> words;
  const int n = size(rng);
  for (int k = 0; k < n; ++k) {
    const double x = u(rng);
    words.push_back(static_cast<WordId>(x * x * vocabulary));
  }
  return Signature::fromWords(words);
}

// Brute force: eq. 5 against every accepted location, non-zero ones only, sorted by id.
std::vector<std::pair<LocationId, double>> bruteForce(
    const std::map<LocationId, Signature>& locations, const Signature& query,
    const InvertedIndex::CandidateFilter& accept) {
  std::vector<std::pair<LocationId, double>> out;
  for (const auto& [id, sig] : locations) {
    if (accept && !accept(id)) continue;
    if (pairedFeatures(query, sig) > 0) out.emplace_back(id, similarity(query, sig));
  }
  return out;
}

void expectIndexMatchesBruteForce(const InvertedIndex& index,
                                  const std::map<LocationId, Signature>& locations,
                                  std::mt19937_64& rng) {
  const auto even = [](LocationId id) { return id % 2 == 0; };
  for (int q = 0; q < 25; ++q) {
    const Signature query = randomSignature(rng, 400);
    for (const InvertedIndex::CandidateFilter& filter :
         {InvertedIndex::CandidateFilter(), InvertedIndex::CandidateFilter(even)}) {
      const auto fast = index.similarities(query, filter);
      const auto slow = bruteForce(locations, query, filter);
      ASSERT_EQ(fast.size(), slow.size());
      for (std::size_t k = 0; k < fast.size(); ++k) {
        EXPECT_EQ(fast[k].location, slow[k].first);
        EXPECT_EQ(fast[k].similarity, slow[k].second);  // same formula: bit-identical
        EXPECT_EQ(fast[k].paired, pairedFeatures(query, locations.at(fast[k].location)));
      }
    }
  }
}

// Refcounts implied by the signatures: locations holding each word.
std::map<WordId, std::size_t> expectedReferences(const std::map<LocationId, Signature>& locations) {
  std::map<WordId, std::size_t> refs;
  for (const auto& [id, sig] : locations) {
    for (const auto& e : sig.entries()) ++refs[e.word];
  }
  return refs;
}

TEST(InvertedIndex, MatchesBruteForceThroughAddsRemovesAndReplaces) {
  std::mt19937_64 rng(42);
  InvertedIndex index;
  std::map<LocationId, Signature> locations;
  std::set<WordId> referenced;  // tracked only through the returned change lists
  auto apply = [&referenced](const WordChanges& c) {
    for (WordId w : c.referenced) EXPECT_TRUE(referenced.insert(w).second) << w;
    for (WordId w : c.unreferenced) EXPECT_EQ(referenced.erase(w), 1u) << w;
    EXPECT_TRUE(std::is_sorted(c.referenced.begin(), c.referenced.end()));
    EXPECT_TRUE(std::is_sorted(c.unreferenced.begin(), c.unreferenced.end()));
  };
  for (LocationId id = 0; id < 300; ++id) {
    locations[id] = randomSignature(rng, 400);
    apply(index.add(id, locations[id]));
  }
  expectIndexMatchesBruteForce(index, locations, rng);

  std::uniform_int_distribution<LocationId> pick(0, 299);
  for (int step = 0; step < 200; ++step) {
    const LocationId id = pick(rng);
    if (locations.count(id) && step % 3 == 0) {
      apply(index.remove(id));
      locations.erase(id);
    } else if (locations.count(id)) {
      locations[id] = randomSignature(rng, 400);
      apply(index.replace(id, locations[id]));
    } else {
      locations[id] = randomSignature(rng, 400);
      apply(index.add(id, locations[id]));
    }
  }
  expectIndexMatchesBruteForce(index, locations, rng);

  const auto refs = expectedReferences(locations);
  EXPECT_EQ(index.wordCount(), refs.size());
  EXPECT_EQ(referenced.size(), refs.size());
  for (const auto& [word, count] : refs) {
    EXPECT_EQ(index.referenceCount(word), count) << word;
    EXPECT_TRUE(referenced.count(word)) << word;
  }
  EXPECT_EQ(index.locationCount(), locations.size());
}

TEST(InvertedIndex, WordsLeaveAndComeBackAsLocationsMoveBetweenTiers) {
  // Transfers and retrievals drop and re-add whole signatures, so words leave the index and
  // return by the thousand: every count must follow, whichever words shared a table cell.
  std::mt19937_64 rng(7);
  InvertedIndex index;
  std::map<LocationId, Signature> locations;
  std::map<LocationId, Signature> away;  // removed, to come back later
  std::uniform_int_distribution<int> coin(0, 2);
  for (LocationId id = 0; id < 400; ++id) {
    locations[id] = randomSignature(rng, 20000);
    index.add(id, locations[id]);
  }
  for (int step = 0; step < 4000; ++step) {
    if ((coin(rng) != 0 || away.empty()) && !locations.empty()) {
      auto it = std::next(locations.begin(),
                          std::uniform_int_distribution<std::size_t>(0, locations.size() - 1)(rng));
      index.remove(it->first);
      away.insert(*it);
      locations.erase(it);
    } else {
      auto it = std::next(away.begin(),
                          std::uniform_int_distribution<std::size_t>(0, away.size() - 1)(rng));
      index.add(it->first, it->second);
      locations.insert(*it);
      away.erase(it);
    }
    if (step % 250 != 0) continue;
    const auto refs = expectedReferences(locations);
    ASSERT_EQ(index.wordCount(), refs.size()) << "step " << step;
    for (const auto& [word, count] : refs) ASSERT_EQ(index.referenceCount(word), count) << word;
    for (const auto& [id, signature] : away)
      for (const auto& e : signature.entries())
        if (!refs.count(e.word)) {
          ASSERT_FALSE(index.isReferenced(e.word)) << e.word;
        }
  }
}

TEST(InvertedIndex, FreedWordCounterMatchesJointRemoval) {
  // A vocabulary of 3000 words over 120 bags: most words are shared by a few locations, some
  // by one, so setting locations aside frees words gradually.
  std::mt19937_64 rng(8);
  InvertedIndex index;
  for (LocationId id = 0; id < 120; ++id) index.add(id, randomSignature(rng, 3000));
  FreedWordCounter counter(index);
  std::vector<LocationId> aside;
  std::size_t previous = 0;
  for (LocationId id = 0; id < 120; id += 2) {
    aside.push_back(id);
    const std::size_t step = counter.setAside(id);
    EXPECT_EQ(counter.freed(), previous + step);
    EXPECT_EQ(counter.freed(), index.wordsFreedByRemoving(aside).size()) << id;
    previous = counter.freed();
  }
  EXPECT_GT(counter.freed(), 0u);
  EXPECT_EQ(counter.setAside(0), 0u);      // twice counts nothing
  EXPECT_EQ(index.locationCount(), 120u);  // the index itself is untouched
}

TEST(InvertedIndex, ReportsWordsEnteringAndLeaving) {
  InvertedIndex index;
  WordChanges c = index.add(10, Signature::fromWords({1, 2, 2}));
  EXPECT_EQ(c.referenced, (std::vector<WordId>{1, 2}));
  EXPECT_TRUE(c.unreferenced.empty());
  c = index.add(11, Signature::fromWords({3, 2}));
  EXPECT_EQ(c.referenced, (std::vector<WordId>{3}));
  EXPECT_EQ(index.referenceCount(2), 2u);
  EXPECT_EQ(index.wordsFreedByRemoving({10}), (std::vector<WordId>{1}));
  EXPECT_EQ(index.wordsFreedByRemoving({10, 11}), (std::vector<WordId>{1, 2, 3}));
  c = index.remove(10);
  EXPECT_EQ(c.unreferenced, (std::vector<WordId>{1}));
  EXPECT_TRUE(c.referenced.empty());
  // Replace {2, 3} by {3, 4}: 2 leaves, 4 enters, 3 stays out of both lists.
  c = index.replace(11, Signature::fromWords({3, 4}));
  EXPECT_EQ(c.unreferenced, (std::vector<WordId>{2}));
  EXPECT_EQ(c.referenced, (std::vector<WordId>{4}));
  c = index.remove(11);
  EXPECT_EQ(c.unreferenced, (std::vector<WordId>{3, 4}));
  EXPECT_EQ(index.wordCount(), 0u);
  EXPECT_THROW(index.remove(11), Error);
  index.add(12, Signature());
  EXPECT_THROW(index.add(12, Signature::fromWords({1})), Error);
}

TEST(InvertedIndex, TouchesOnlyLocationsSharingAWord) {
  // 2000 locations with private words; the query shares words with two of them. The candidate
  // filter must be consulted only for those two, proving the query never scans all locations.
  InvertedIndex index;
  for (LocationId id = 0; id < 2000; ++id) {
    index.add(id, Signature::fromWords({id * 10, id * 10 + 1, id * 10 + 2}));
  }
  int consulted = 0;
  const auto sims =
      index.similarities(Signature::fromWords({70, 71, 15000, 999999}), [&consulted](LocationId) {
        ++consulted;
        return true;
      });
  EXPECT_EQ(consulted, 2);
  ASSERT_EQ(sims.size(), 2u);
  EXPECT_EQ(sims[0].location, 7);
  EXPECT_DOUBLE_EQ(sims[0].similarity, 2.0 / 4.0);  // 2 pairs over max(4, 3)
  EXPECT_EQ(sims[1].location, 1500);
  EXPECT_DOUBLE_EQ(sims[1].similarity, 1.0 / 4.0);
}

}  // namespace
}  // namespace placedb
