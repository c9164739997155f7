// The kd-forest's size follows the words in RAM, not every word ever made, and its stored form
// (internal nodes, or a schema-2 split log to convert) rebuilds trees that answer the same.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "legacy_split_log.h"
#include "placedb/error.h"
#include "vocabulary/vocabulary.h"

namespace placedb::vocab {
namespace {

constexpr int kDim = 16;

cv::Mat randomRows(std::mt19937& rng, int n) {
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  cv::Mat out(n, kDim, CV_32F);
  for (int i = 0; i < n; ++i)
    for (int d = 0; d < kDim; ++d) out.at<float>(i, d) = u(rng);
  return out;
}

VocabularyOptions smallBuckets() {
  VocabularyOptions o;
  o.leaf_size = 4;
  o.checks = 16;  // approximate: answers depend on the trees' shape
  return o;
}

// A sliding window of words, as a bounded working memory makes: each round inserts `batch` new
// words and erases the oldest `batch`, so `live` words stay in RAM while the history grows.
struct SlidingWords {
  std::mt19937 rng{5};
  std::int64_t next_id = 0;
  std::vector<std::int64_t> live;

  void round(Vocabulary& v, int batch) {
    cv::Mat rows = randomRows(rng, batch);
    std::vector<std::int64_t> ids, frames(static_cast<std::size_t>(batch), 0);
    for (int i = 0; i < batch; ++i) ids.push_back(next_id++);
    v.insert(ids, rows, frames);
    live.insert(live.end(), ids.begin(), ids.end());
  }
  void dropOldest(Vocabulary& v, int count) {
    std::vector<std::int64_t> gone(live.begin(), live.begin() + count);
    v.erase(gone);
    live.erase(live.begin(), live.begin() + count);
  }
};

TEST(KdForestSize, FollowsTheWordsInRamNotTheHistory) {
  Vocabulary v(smallBuckets(), kDim, "test");
  SlidingWords words;
  for (int r = 0; r < 10; ++r) words.round(v, 200);  // 2,000 live words
  const std::size_t full_nodes = v.indexNodeCount();
  std::size_t halfway_nodes = 0;
  for (int r = 0; r < 100; ++r) {  // 20,000 more words pass through
    words.round(v, 200);
    words.dropOldest(v, 200);
    if (r == 49) halfway_nodes = v.indexNodeCount();
  }
  ASSERT_EQ(v.size(), 2000u);
  // With no empty leaf, each tree has at most as many leaves as live words.
  EXPECT_LT(v.state().nodes.size(), std::size_t(smallBuckets().kd_trees) * v.size());
  // Freed nodes are reused: the allocation levels off (buckets hold fewer points after churn
  // than when first filled, so the level is above the freshly grown forest's). A forest that
  // never gives nodes back keeps growing: here 3 times the fresh size after 100 rounds, 2.4 after
  // 50, even though new words land in the same region of space as the old ones.
  EXPECT_LT(v.indexNodeCount(), halfway_nodes + halfway_nodes / 10)
      << "from " << halfway_nodes << " after 50 rounds";
  EXPECT_LT(v.indexNodeCount(), 2 * full_nodes) << "fresh forest of 2,000 words: " << full_nodes;

  words.dropOldest(v, 2000);
  EXPECT_TRUE(v.state().nodes.empty()) << "an empty vocabulary keeps internal nodes";
}

// Builds a vocabulary, then restores another from `state` with the same words and compares
// their approximate answers.
void expectSameAnswers(const Vocabulary& grown, const IndexState& state, int probes = 300) {
  std::vector<std::int64_t> ids = grown.ids(), frames;
  cv::Mat rows;
  for (std::int64_t id : ids) {
    frames.push_back(grown.createdFrame(id));
    rows.push_back(cv::Mat(1, kDim, CV_32F, const_cast<float*>(grown.descriptor(id))).clone());
  }
  Vocabulary restored(smallBuckets(), kDim, "test");
  restored.restore(state, ids, rows, frames);
  std::mt19937 rng(17);
  cv::Mat probe = randomRows(rng, probes);
  for (int i = 0; i < probe.rows; ++i)
    ASSERT_EQ(grown.knn(probe.ptr<float>(i), 3), restored.knn(probe.ptr<float>(i), 3)) << i;
  EXPECT_EQ(restored.state().nodes.size(), grown.state().nodes.size());
}

TEST(KdForestNodes, SchemaTwoSplitLogConvertsToTheSameTrees) {
  Vocabulary grown(smallBuckets(), kDim, "test");
  SlidingWords words;
  for (int r = 0; r < 30; ++r) {
    words.round(grown, 100);
    if (r >= 10) words.dropOldest(grown, 100);
  }
  IndexState legacy = grown.state();
  legacy.legacy_splits =
      testing::legacySplitLog(legacy.nodes, smallBuckets().kd_trees, /*padding=*/40);
  legacy.nodes.clear();
  expectSameAnswers(grown, legacy);

  // The converted forest asks for a full rewrite of the stored nodes.
  std::vector<std::int64_t> ids = grown.ids(), frames(ids.size(), 0);
  cv::Mat rows;
  for (std::int64_t id : ids)
    rows.push_back(cv::Mat(1, kDim, CV_32F, const_cast<float*>(grown.descriptor(id))).clone());
  Vocabulary converted(smallBuckets(), kDim, "test");
  converted.restore(legacy, ids, rows, frames);
  ForestChanges changes;
  converted.takeIndexChanges(&changes);
  EXPECT_TRUE(changes.full);
  EXPECT_EQ(changes.upserts.size(), grown.state().nodes.size());
}

TEST(KdForestNodes, RestoredFromNodesAnswersTheSame) {
  Vocabulary grown(smallBuckets(), kDim, "test");
  SlidingWords words;
  for (int r = 0; r < 20; ++r) {
    words.round(grown, 100);
    if (r >= 5) words.dropOldest(grown, 100);
  }
  expectSameAnswers(grown, grown.state());
}

TEST(KdForestNodes, RestoredForestErasesAndGrowsAsTheOriginal) {
  // Erasing finds each word's leaf and that leaf's parent from tables the restore fills (not by
  // descending the trees): after a restore they must lead to the same splices as the original.
  Vocabulary grown(smallBuckets(), kDim, "test");
  SlidingWords words;
  for (int r = 0; r < 12; ++r) {
    words.round(grown, 100);
    if (r >= 4) words.dropOldest(grown, 100);
  }
  std::vector<std::int64_t> ids = grown.ids(), frames;
  cv::Mat rows;
  for (std::int64_t id : ids) {
    frames.push_back(grown.createdFrame(id));
    rows.push_back(cv::Mat(1, kDim, CV_32F, const_cast<float*>(grown.descriptor(id))).clone());
  }
  Vocabulary restored(smallBuckets(), kDim, "test");
  restored.restore(grown.state(), ids, rows, frames);
  SlidingWords twin = words;
  for (int r = 0; r < 8; ++r) {  // every word restored is erased by the end
    words.round(grown, 100);
    words.dropOldest(grown, 150);
    twin.round(restored, 100);
    twin.dropOldest(restored, 150);
    ASSERT_EQ(restored.state().nodes, grown.state().nodes) << "round " << r;
  }
  expectSameAnswers(grown, restored.state());
}

TEST(KdForestNodes, DamagedNodesAreRefused) {
  Vocabulary grown(smallBuckets(), kDim, "test");
  SlidingWords words;
  words.round(grown, 300);
  const IndexState good = grown.state();
  ASSERT_GT(good.nodes.size(), 10u);
  auto refused = [&](IndexState state, const char* what) {
    Vocabulary v(smallBuckets(), kDim, "test");
    EXPECT_THROW(v.restore(state, {}, cv::Mat(0, kDim, CV_32F), {}), Error) << what;
  };
  IndexState twice = good;
  twice.nodes[5].left = twice.nodes[3].left;  // one child, two parents
  refused(twice, "child named twice");
  IndexState orphan = good;
  orphan.nodes.push_back({0, 100000, 100001, 100002, 0, 0.f});  // no path from the root
  refused(orphan, "unreachable node");
  IndexState bad_dim = good;
  bad_dim.nodes[2].dim = kDim;
  refused(bad_dim, "dimension out of range");
  IndexState both = good;
  both.legacy_splits = testing::legacySplitLog(good.nodes, smallBuckets().kd_trees);
  refused(both, "nodes and a split log");
}

}  // namespace
}  // namespace placedb::vocab
