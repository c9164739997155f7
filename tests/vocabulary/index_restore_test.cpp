// Index membership (insert/erase), search exactness at unlimited checks, and the engine's hard
// requirement: bit-identical answers across runs and after a restart from the persisted state.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <random>
#include <vector>

#include "placedb/error.h"
#include "vocabulary/vocabulary.h"

namespace placedb::vocab {
namespace {

constexpr int kDim = 8;

// Clustered unit vectors: a few hundred centres, features scattered around them.
class ClusteredSource {
 public:
  explicit ClusteredSource(std::uint32_t seed, int centres = 300) : rng_(seed) {
    std::normal_distribution<float> gauss(0.f, 1.f);
    centres_ = cv::Mat(centres, kDim, CV_32F);
    for (int i = 0; i < centres; ++i) {
      for (int d = 0; d < kDim; ++d) centres_.at<float>(i, d) = gauss(rng_);
      cv::normalize(centres_.row(i), centres_.row(i));
    }
  }
  cv::Mat next(int n) {
    std::normal_distribution<float> noise(0.f, 0.12f);
    std::uniform_int_distribution<int> pick(0, centres_.rows - 1);
    cv::Mat out(n, kDim, CV_32F);
    for (int i = 0; i < n; ++i) {
      const int c = pick(rng_);
      for (int d = 0; d < kDim; ++d) out.at<float>(i, d) = centres_.at<float>(c, d) + noise(rng_);
      cv::normalize(out.row(i), out.row(i));
    }
    return out;
  }
  std::mt19937& rng() { return rng_; }

 private:
  std::mt19937 rng_;
  cv::Mat centres_;
};

VocabularyOptions smallIndex() {
  VocabularyOptions o;
  o.leaf_size = 4;  // many splits even on a small vocabulary
  o.checks = 12;    // approximate enough that a different tree would answer differently
  o.t_nd2 = 0.05f;
  return o;
}

std::vector<std::pair<std::int64_t, float>> bruteForce(const Vocabulary& v, const float* q, int k) {
  std::vector<std::pair<float, std::int64_t>> all;
  for (std::int64_t id : v.ids()) all.emplace_back(squaredDistance(q, v.descriptor(id), kDim), id);
  std::sort(all.begin(), all.end());
  std::vector<std::pair<std::int64_t, float>> out;
  for (int i = 0; i < k && i < int(all.size()); ++i) {
    out.emplace_back(all[i].second, std::sqrt(all[i].first));
  }
  return out;
}

TEST(Index, UnlimitedChecksMatchBruteForceIncludingTies) {
  VocabularyOptions o = smallIndex();
  o.checks = 1000000;
  Vocabulary v(o, kDim, "test");
  ClusteredSource source(1);
  cv::Mat words = source.next(1500);
  words.row(3).copyTo(words.row(700));  // an exact tie: the smaller id must come first
  std::vector<std::int64_t> ids(words.rows), frames(words.rows, 0);
  for (int i = 0; i < words.rows; ++i) ids[i] = i;
  v.insert(ids, words, frames);
  cv::Mat queries = source.next(100);
  words.row(3).copyTo(queries.row(0));
  for (int i = 0; i < queries.rows; ++i) {
    EXPECT_EQ(v.knn(queries.ptr<float>(i), 5), bruteForce(v, queries.ptr<float>(i), 5)) << i;
  }
  EXPECT_EQ(v.knn(queries.ptr<float>(0), 2)[0].first, 3);
  EXPECT_EQ(v.knn(queries.ptr<float>(0), 2)[1].first, 700);
}

TEST(Index, ErasedWordsAreNeverReturnedAndReinsertedOnesAre) {
  VocabularyOptions o = smallIndex();
  o.fixed = true;
  Vocabulary v(o, kDim, "test");
  ClusteredSource source(2);
  cv::Mat words = source.next(800);
  std::vector<std::int64_t> ids(words.rows), frames(words.rows);
  for (int i = 0; i < words.rows; ++i) ids[i] = i, frames[i] = i / 100;
  v.insert(ids, words, frames);
  EXPECT_EQ(v.nextWordId(), 800);

  std::vector<std::int64_t> erased;
  for (int i = 0; i < words.rows; i += 3) erased.push_back(i);
  v.erase(erased);
  EXPECT_EQ(v.size(), 800u - erased.size());
  cv::Mat erased_rows(int(erased.size()), kDim, CV_32F);
  for (std::size_t i = 0; i < erased.size(); ++i) {
    words.row(int(erased[i])).copyTo(erased_rows.row(int(i)));
    EXPECT_FALSE(v.contains(erased[i]));
    EXPECT_EQ(v.descriptor(erased[i]), nullptr);
    for (const auto& [id, dist] : v.knn(words.ptr<float>(int(erased[i])), 10)) {
      EXPECT_NE(id % 3, 0) << "erased word " << id << " returned by knn";
    }
  }
  const Quantization q = v.quantize(erased_rows, 9);
  for (std::int64_t w : q.word_of_feature) EXPECT_NE(w % 3, 0) << "erased word " << w;

  // Back from LTM: found again, at distance 0, with its created frame.
  std::vector<std::int64_t> back = {erased[5], erased[6]};
  cv::Mat back_rows;
  cv::vconcat(words.row(int(back[0])), words.row(int(back[1])), back_rows);
  v.insert(back, back_rows, {42, 43});
  EXPECT_TRUE(v.contains(back[0]));
  EXPECT_EQ(v.createdFrame(back[1]), 43);
  EXPECT_EQ(v.knn(words.ptr<float>(int(back[0])), 1)[0], std::make_pair(back[0], 0.f));
  EXPECT_EQ(v.quantize(back_rows, 10).word_of_feature, back);

  EXPECT_THROW(v.insert({back[0]}, back_rows.row(0), {1}), Error);  // already in RAM
  EXPECT_THROW(v.erase({erased[0]}), Error);                        // not in RAM

  // A word given twice, in order or not, is refused before anything enters the index.
  const std::size_t size = v.size();
  cv::Mat three;
  cv::vconcat(std::vector<cv::Mat>{words.row(int(erased[0])), words.row(int(erased[1])),
                                   words.row(int(erased[0]))},
              three);
  for (const std::vector<std::int64_t>& ids :
       {std::vector<std::int64_t>{erased[0], erased[0], erased[1]},
        std::vector<std::int64_t>{erased[1], erased[0], erased[1]}}) {
    try {
      v.insert(ids, three, {1, 2, 3});
      ADD_FAILURE() << "a word given twice was inserted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("given twice"), std::string::npos) << e.what();
    }
    EXPECT_EQ(v.size(), size);
    EXPECT_FALSE(v.contains(erased[0]));
    EXPECT_FALSE(v.contains(erased[1]));
  }
}

// A recorded sequence of calls, replayed on vocabularies that may be restarted along the way.
struct Step {
  cv::Mat image;
  std::vector<std::int64_t> erase;  // chosen from the words in RAM before the step
  std::vector<std::int64_t> retrieve;
};

struct Outcome {
  std::vector<Quantization> quantizations;
  std::vector<std::vector<std::pair<std::int64_t, float>>> probes;
  IndexState final_state;
  std::size_t erased = 0, retrieved = 0;
};

bool sameBits(const Quantization& a, const Quantization& b) {
  return a.word_of_feature == b.word_of_feature && a.created_words == b.created_words &&
         a.distance_of_feature.size() == b.distance_of_feature.size() &&
         std::memcmp(a.distance_of_feature.data(), b.distance_of_feature.data(),
                     a.distance_of_feature.size() * sizeof(float)) == 0 &&
         std::memcmp(&a.mean_error, &b.mean_error, sizeof(double)) == 0;
}

// Runs the scenario; if restart_at >= 0, the vocabulary is rebuilt with restore() from the
// serialised state and the words in RAM (as the engine would load them from SQLite) after that
// step. `ltm` plays SQLite: every word ever created, with its descriptor.
// The restart goes through the engine's path: the stored node table is kept up to date with
// takeIndexChanges() after every step, and the restored state is read from it.
Outcome run(const std::vector<Step>& steps, int restart_at) {
  const VocabularyOptions o = smallIndex();
  auto v = std::make_unique<Vocabulary>(o, kDim, "test");
  std::map<std::pair<std::uint8_t, std::uint32_t>, ForestNode> stored;
  ForestChanges changes;
  std::map<std::int64_t, std::pair<cv::Mat, std::int64_t>> ltm;
  Outcome out;
  ClusteredSource probes(99);
  for (std::size_t s = 0; s < steps.size(); ++s) {
    out.quantizations.push_back(v->quantize(steps[s].image, std::int64_t(s)));
    for (std::int64_t id : out.quantizations.back().created_words) {
      ltm[id] = {cv::Mat(1, kDim, CV_32F, const_cast<float*>(v->descriptor(id))).clone(),
                 std::int64_t(s)};
    }
    std::vector<std::int64_t> to_erase;
    for (std::int64_t id : steps[s].erase) {
      if (v->contains(id)) to_erase.push_back(id);
    }
    v->erase(to_erase);
    out.erased += to_erase.size();
    std::vector<std::int64_t> back, frames;
    cv::Mat rows;
    for (std::int64_t id : steps[s].retrieve) {
      if (v->contains(id) || !ltm.count(id)) continue;
      back.push_back(id);
      frames.push_back(ltm[id].second);
      rows.push_back(ltm[id].first);
    }
    v->insert(back, rows, frames);
    out.retrieved += back.size();
    cv::Mat probe = probes.next(5);
    for (int i = 0; i < probe.rows; ++i) out.probes.push_back(v->knn(probe.ptr<float>(i), 3));

    v->takeIndexChanges(&changes);
    if (changes.full) stored.clear();
    for (const auto& key : changes.deletions) stored.erase(key);
    for (const ForestNode& n : changes.upserts) stored[{n.tree, n.node}] = n;

    if (int(s) == restart_at) {
      IndexState from_store = v->state();
      from_store.nodes.clear();
      for (const auto& entry : stored) from_store.nodes.push_back(entry.second);
      EXPECT_TRUE(from_store == v->state()) << "the stored copy drifted from the forest";
      const std::vector<std::uint8_t> bytes = from_store.serialize();
      std::vector<std::int64_t> ids = v->ids(), frames_in_ram;
      cv::Mat descriptors;
      for (std::int64_t id : ids) {
        frames_in_ram.push_back(v->createdFrame(id));
        descriptors.push_back(ltm[id].first);
      }
      v = std::make_unique<Vocabulary>(o, kDim, "test");
      v->restore(IndexState::deserialize(bytes), ids, descriptors, frames_in_ram);
      v->takeIndexChanges(&changes);
      EXPECT_TRUE(changes.empty()) << "a restored forest reports changes it did not make";
    }
  }
  out.final_state = v->state();
  return out;
}

std::vector<Step> makeScenario(std::uint32_t seed, int steps) {
  ClusteredSource source(seed);
  std::vector<Step> out;
  std::int64_t words_so_far = 0;
  for (int s = 0; s < steps; ++s) {
    Step step;
    step.image = source.next(60);
    // Ids are guesses of what exists; run() skips those not in RAM / not created yet.
    std::uniform_int_distribution<std::int64_t> any(0, std::max<std::int64_t>(0, words_so_far));
    for (int i = 0; i < 25; ++i) step.erase.push_back(any(source.rng()));
    for (int i = 0; i < 15; ++i) step.retrieve.push_back(any(source.rng()));
    std::sort(step.erase.begin(), step.erase.end());
    step.erase.erase(std::unique(step.erase.begin(), step.erase.end()), step.erase.end());
    std::sort(step.retrieve.begin(), step.retrieve.end());
    step.retrieve.erase(std::unique(step.retrieve.begin(), step.retrieve.end()),
                        step.retrieve.end());
    words_so_far += 45;
    out.push_back(step);
  }
  return out;
}

void expectSame(const Outcome& a, const Outcome& b) {
  ASSERT_EQ(a.quantizations.size(), b.quantizations.size());
  for (std::size_t i = 0; i < a.quantizations.size(); ++i) {
    EXPECT_TRUE(sameBits(a.quantizations[i], b.quantizations[i])) << "step " << i;
  }
  EXPECT_EQ(a.probes, b.probes);
  EXPECT_TRUE(a.final_state == b.final_state);
}

TEST(Determinism, TwoRunsGiveBitIdenticalResults) {
  const std::vector<Step> steps = makeScenario(7, 40);
  const Outcome first = run(steps, -1);
  const Outcome second = run(steps, -1);
  expectSame(first, second);
  EXPECT_GT(first.final_state.nodes.size(), 100u);
  EXPECT_GT(first.erased, 200u);
  EXPECT_GT(first.retrieved, 100u);
}

TEST(Determinism, RestartAfterAnyStepGivesBitIdenticalResults) {
  const std::vector<Step> steps = makeScenario(11, 40);
  const Outcome uninterrupted = run(steps, -1);
  for (int k : {0, 1, 7, 19, 38}) {
    SCOPED_TRACE("restart after step " + std::to_string(k));
    expectSame(uninterrupted, run(steps, k));
  }
}

// The test above would notice a restore that loses the tree: re-inserting the same words into a
// fresh forest gives other splits, and the approximate answers change.
TEST(Determinism, TreeShapeMattersForApproximateAnswers) {
  const std::vector<Step> steps = makeScenario(11, 40);
  VocabularyOptions o = smallIndex();
  Vocabulary grown(o, kDim, "test");
  for (std::size_t s = 0; s < steps.size(); ++s) grown.quantize(steps[s].image, std::int64_t(s));
  std::vector<std::int64_t> ids = grown.ids(), frames;
  cv::Mat rows;
  std::reverse(ids.begin(), ids.end());
  for (std::int64_t id : ids) {
    frames.push_back(0);
    rows.push_back(cv::Mat(1, kDim, CV_32F, const_cast<float*>(grown.descriptor(id))).clone());
  }
  Vocabulary rebuilt(o, kDim, "test");
  rebuilt.insert(ids, rows, frames);
  EXPECT_FALSE(rebuilt.state() == grown.state());
  ClusteredSource probes(3);
  cv::Mat probe = probes.next(400);
  int differing = 0;
  for (int i = 0; i < probe.rows; ++i) {
    differing += grown.knn(probe.ptr<float>(i), 2) != rebuilt.knn(probe.ptr<float>(i), 2);
  }
  EXPECT_GT(differing, 0);
}

TEST(IndexStateBytes, RoundTripAndRefusal) {
  Vocabulary v(smallIndex(), kDim, "test");
  ClusteredSource source(4);
  v.quantize(source.next(200), 0);
  const IndexState state = v.state();
  // No word left yet: every tree is binary with no free node.
  EXPECT_EQ(2 * state.nodes.size() + std::size_t(smallIndex().kd_trees), v.indexNodeCount());
  EXPECT_EQ(state.next_word_id, v.nextWordId());
  std::vector<std::uint8_t> bytes = state.serialize();
  EXPECT_TRUE(IndexState::deserialize(bytes) == state);
  EXPECT_EQ(IndexState::deserialize(bytes).serialize(), bytes);
  std::vector<std::uint8_t> cut(bytes.begin(), bytes.end() - 3);
  EXPECT_THROW(IndexState::deserialize(cut), Error);
  bytes[0] = 'X';
  EXPECT_THROW(IndexState::deserialize(bytes), Error);

  VocabularyOptions other = smallIndex();
  other.leaf_size = 8;
  Vocabulary mismatched(other, kDim, "test");
  EXPECT_THROW(mismatched.restore(state, {}, cv::Mat(), {}), Error);
}

}  // namespace
}  // namespace placedb::vocab
