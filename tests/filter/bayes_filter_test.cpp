// Likelihood, posterior normalisation, the decision rules and exact state save/restore.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>

#include "filter/bayes_filter.h"
#include "filter/inverted_index.h"
#include "placedb/error.h"

namespace placedb {
namespace {

LinkGraph chainOver(const std::vector<LocationId>& ids) {
  LinkGraph g;
  for (std::size_t k = 0; k < ids.size(); ++k) {
    g.addNode(ids[k]);
    if (k > 0) g.addLink(ids[k - 1], ids[k]);
  }
  return g;
}

// The hand computations below use RTAB-Map's 2013 decision settings, not the engine's defaults.
BayesFilterSettings rtabmap2013() {
  BayesFilterSettings s;
  s.t_loop = 0.11;
  s.loop_ratio = 0.9;
  return s;
}

double posteriorTotal(const BayesFilter& f) {
  double total = 0.0;
  for (const auto& entry : f.posterior()) total += entry.second;
  return total;
}

// Ten features each: location k shares `shared` words (1..shared) with the query words 1..10, the
// rest are words of its own, so its similarity is shared / 10.
Signature tenFeatures(int shared, WordId private_base) {
  std::vector<WordId> words;
  for (int w = 1; w <= shared; ++w) words.push_back(w);
  for (int w = shared; w < 10; ++w) words.push_back(private_base + w);
  return Signature::fromWords(words);
}

TEST(Likelihood, HandComputedExampleFromSignatures) {
  InvertedIndex index;
  const std::map<LocationId, int> shared{{1, 1}, {2, 2}, {3, 3}, {4, 6}, {5, 0}};
  for (const auto& [id, n] : shared) index.add(id, tenFeatures(n, 1000 * id));
  std::vector<WordId> query_words;
  for (WordId w = 1; w <= 10; ++w) query_words.push_back(w);
  const auto sims = index.similarities(Signature::fromWords(query_words));
  ASSERT_EQ(sims.size(), 4u);  // location 5 shares nothing
  std::vector<double> by_location(5, 0.0);
  for (const auto& s : sims) by_location[static_cast<std::size_t>(s.location - 1)] = s.similarity;
  EXPECT_DOUBLE_EQ(by_location[3], 0.6);

  // Non-zero sims 0.1, 0.2, 0.3, 0.6: mu = 0.3; squared deviations .04 .01 0 .09 sum to .14,
  // sigma = sqrt(.14 / 4) = 0.187082869. Only 0.6 >= mu + sigma = 0.487: its likelihood is
  // (0.6 - 0.187082869) / 0.3 = 1.376390436; the others get 1. New place: 0.3 / 0.187082869 + 1
  // = 2.603567451.
  const Likelihood l = BayesFilter::likelihood(by_location);
  EXPECT_NEAR(l.mean, 0.3, 1e-15);
  EXPECT_NEAR(l.stddev, 0.187082869338697, 1e-12);
  EXPECT_EQ(l.nonzero, 4u);
  EXPECT_FALSE(l.degenerate);
  EXPECT_NEAR(l.of_location[3], 1.376390435537676, 1e-12);
  for (std::size_t k : {0u, 1u, 2u, 4u}) EXPECT_EQ(l.of_location[k], 1.0) << k;
  EXPECT_NEAR(l.new_place, 2.603567451474547, 1e-12);

  // First update on the chain 1-2-3-4-5 from p(-1) = 1: prediction 0.9 for -1, 0.1/5 = 0.02 each.
  // Joint: -1 0.9 x 2.6035675 = 2.3432107, location 4 0.02 x 1.3763904 = 0.0275278, the other four
  // 0.02 each; total 2.4507385. Posterior: -1 0.956124324, 4 0.011232454, others 0.008160805.
  BayesFilter filter(rtabmap2013());
  const FilterOutcome out = filter.update({1, 2, 3, 4, 5}, sims, chainOver({1, 2, 3, 4, 5}));
  EXPECT_NEAR(filter.posteriorOf(kNewPlace), 0.956124324137007, 1e-12);
  EXPECT_NEAR(filter.posteriorOf(4), 0.011232454438465, 1e-12);
  EXPECT_NEAR(filter.posteriorOf(2), 0.008160805356132, 1e-12);
  EXPECT_EQ(out.hypothesis, 4);
  EXPECT_NEAR(out.hypothesis_posterior, 0.011232454438465, 1e-12);
  EXPECT_NEAR(out.score, 1.0 - 0.956124324137007, 1e-12);
  EXPECT_EQ(out.reason, RejectReason::kBelowThreshold);
  EXPECT_FALSE(out.accepted);
}

TEST(Likelihood, DegenerateCasesFavourNoLocation) {
  Likelihood none = BayesFilter::likelihood({0.0, 0.0, 0.0});
  EXPECT_TRUE(none.degenerate);
  EXPECT_EQ(none.new_place, 2.0);
  EXPECT_EQ(none.of_location, (std::vector<double>{1.0, 1.0, 1.0}));
  // A single non-zero similarity, or several equal ones: sigma = 0.
  for (const std::vector<double>& sims :
       {std::vector<double>{0.0, 0.7, 0.0}, std::vector<double>{0.1, 0.1, 0.1, 0.0}}) {
    const Likelihood l = BayesFilter::likelihood(sims);
    EXPECT_TRUE(l.degenerate);
    EXPECT_EQ(l.new_place, 2.0);
    for (double v : l.of_location) EXPECT_EQ(v, 1.0);
  }
  EXPECT_TRUE(BayesFilter::likelihood({}).degenerate);
}

TEST(BayesFilter, PosteriorSumsToOneAndNewLocationsEnterWithPriorZero) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  BayesFilter filter;
  std::vector<LocationId> wm;
  LinkGraph graph;
  for (LocationId frame = 0; frame < 300; ++frame) {
    // A fresh, unlinked location must receive exactly its share of the new-place row,
    // p(-1) x 0.1 / M: its own prior is 0 and no link brings it mass.
    const LocationId fresh = 100000 + frame;
    std::vector<LocationId> with_fresh = wm;
    with_fresh.push_back(fresh);
    const auto predicted = filter.predict(with_fresh, graph);
    const double prior_new_place = frame == 0 ? 1.0 : filter.posteriorOf(kNewPlace);
    EXPECT_EQ(filter.posteriorOf(fresh), 0.0);
    EXPECT_NEAR(predicted.back().second, prior_new_place * 0.1 / with_fresh.size(), 1e-15);

    if (frame % 2 == 0) {  // grow WM along a chain, with an occasional loop-closure link
      wm.push_back(frame);
      graph.addNode(frame);
      if (frame >= 2) graph.addLink(frame - 2, frame);
      if (frame > 40 && frame % 20 == 0) graph.addLink(frame, frame - 40);
    }
    if (frame % 37 == 5 && wm.size() > 10) wm.erase(wm.begin() + 3);  // a transfer to LTM
    std::vector<std::pair<LocationId, double>> sims;
    for (LocationId id : wm) {
      if (u(rng) < 0.3) sims.emplace_back(id, u(rng) < 0.1 ? 0.8 : 0.1 * u(rng));
    }
    const FilterOutcome out = filter.update(wm, sims, graph);
    EXPECT_NEAR(posteriorTotal(filter), 1.0, 1e-12) << frame;
    for (const auto& [id, p] : filter.posterior()) {
      EXPECT_GE(p, 0.0);
      if (id != kNewPlace) {
        EXPECT_TRUE(std::binary_search(wm.begin(), wm.end(), id));
      }
    }
    EXPECT_EQ(filter.posterior().size(), wm.size() + 1);
    EXPECT_NEAR(out.score, 1.0 - out.new_place_posterior, 1e-15);
  }
}

TEST(BayesFilter, LocationsLeavingWmAreDroppedAndTheRestRenormalised) {
  const LinkGraph graph;  // isolated locations: each row keeps 0.9 on itself
  const std::vector<std::pair<LocationId, double>> sims{{2, 0.5}, {3, 0.1}, {4, 0.2}};
  BayesFilter dropped;
  dropped.restore({{{kNewPlace, 0.2}, {1, 0.5}, {2, 0.3}}, 0.0});
  dropped.update({2, 3, 4}, sims, graph);  // location 1 left WM
  BayesFilter renormalised;
  renormalised.restore({{{kNewPlace, 0.2 / 0.5}, {2, 0.3 / 0.5}}, 0.0});
  renormalised.update({2, 3, 4}, sims, graph);
  ASSERT_EQ(dropped.posterior().size(), 4u);
  for (std::size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(dropped.posterior()[k].first, renormalised.posterior()[k].first);
    EXPECT_NEAR(dropped.posterior()[k].second, renormalised.posterior()[k].second, 1e-14);
  }
  EXPECT_EQ(dropped.posteriorOf(1), 0.0);

  // Everything left: the prior restarts at p(-1) = 1, like a first frame.
  BayesFilter emptied;
  emptied.restore({{{kNewPlace, 0.0}, {1, 1.0}}, 0.0});
  emptied.update({2, 3, 4}, sims, graph);
  BayesFilter fresh;
  fresh.update({2, 3, 4}, sims, graph);
  EXPECT_EQ(emptied.posterior(), fresh.posterior());
}

// Ten isolated WM locations 0..9; location 5 looks like the query (sim 0.9), the others weakly
// (0.1). Likelihood: mu = 0.18, sigma = 0.24, location 5 gets (0.9 - 0.24) / 0.18 = 3.667, new
// place 0.18 / 0.24 + 1 = 1.75.
const std::vector<LocationId> kTenWm{0, 1, 2, 3, 4, 5, 6, 7, 8, 9};
std::vector<std::pair<LocationId, double>> tenSims() {
  std::vector<std::pair<LocationId, double>> sims;
  for (LocationId id : kTenWm) sims.emplace_back(id, id == 5 ? 0.9 : 0.1);
  return sims;
}

TEST(Decision, RtabmapRuleThresholdAndRatioTest) {
  const LinkGraph graph;
  // Prior {-1: 0.5, 5: 0.5}. Prediction: -1 0.45 + 0.05 = 0.5; 5 0.45 + 0.005 = 0.455; others
  // 0.005. Joint: -1 0.875, 5 1.668, others 0.045 in all: score = 1.713 / 2.588 = 0.662.
  const FilterState prior{{{kNewPlace, 0.5}, {5, 0.5}}, 0.0};
  BayesFilter filter(rtabmap2013());
  filter.restore(prior);
  FilterOutcome out = filter.update(kTenWm, tenSims(), graph);
  EXPECT_EQ(out.hypothesis, 5);
  EXPECT_NEAR(out.score, 0.6619, 1e-3);
  EXPECT_TRUE(out.accepted);
  EXPECT_EQ(out.reason, RejectReason::kNone);
  EXPECT_EQ(filter.state().previous_score, out.score);

  // Same frame after a frame that scored 0.99: 0.662 < 0.9 x 0.99, the ratio test rejects.
  FilterState after_high = prior;
  after_high.previous_score = 0.99;
  filter.restore(after_high);
  out = filter.update(kTenWm, tenSims(), graph);
  EXPECT_FALSE(out.accepted);
  EXPECT_EQ(out.reason, RejectReason::kRatioTest);
  EXPECT_EQ(out.previous_score, 0.99);
  EXPECT_EQ(out.hypothesis, 5);  // the hypothesis is still reported

  // 0.662 >= 0.9 x 0.7 = 0.63: passes.
  after_high.previous_score = 0.7;
  filter.restore(after_high);
  EXPECT_TRUE(filter.update(kTenWm, tenSims(), graph).accepted);

  // Ratio test off.
  BayesFilterSettings no_ratio = rtabmap2013();
  no_ratio.loop_ratio = 0.0;
  BayesFilter lenient(no_ratio);
  after_high.previous_score = 0.99;
  lenient.restore(after_high);
  EXPECT_TRUE(lenient.update(kTenWm, tenSims(), graph).accepted);

  // From p(-1) = 1 the same frame only scores 0.074 < T_loop = 0.11.
  BayesFilter cold(rtabmap2013());
  out = cold.update(kTenWm, tenSims(), graph);
  EXPECT_NEAR(out.score, 0.0744, 1e-3);
  EXPECT_EQ(out.reason, RejectReason::kBelowThreshold);
}

TEST(Decision, Paper000RuleComparesTheNewPlacePosterior) {
  const LinkGraph graph;
  BayesFilterSettings paper = rtabmap2013();
  paper.rule = DecisionRule::kPaper;
  BayesFilter filter(paper);
  // The frame above: p(-1) = 0.338 is not < 0.11, although RTAB-Map's rule accepts it.
  filter.restore({{{kNewPlace, 0.5}, {5, 0.5}}, 0.0});
  FilterOutcome out = filter.update(kTenWm, tenSims(), graph);
  EXPECT_NEAR(out.new_place_posterior, 0.338, 1e-3);
  EXPECT_EQ(out.reason, RejectReason::kBelowThreshold);
  // Prior {-1: 0.05, 5: 0.95}: prediction -1 0.045 + 0.095 = 0.14, 5 0.855 + 0.0005; joint -1
  // 0.245, 5 3.137, others 0.0045: p(-1) = 0.072 < 0.11 -> accepted, and no ratio test applies
  // even after a previous score of 1.
  filter.restore({{{kNewPlace, 0.05}, {5, 0.95}}, 1.0});
  out = filter.update(kTenWm, tenSims(), graph);
  EXPECT_NEAR(out.new_place_posterior, 0.0723, 1e-3);
  EXPECT_TRUE(out.accepted);
  EXPECT_EQ(out.hypothesis, 5);
}

TEST(Decision, NoHypothesisTiesAndPreviousScoreReset) {
  const LinkGraph graph;
  BayesFilter filter;
  filter.restore({{{kNewPlace, 0.1}, {3, 0.9}}, 0.8});
  FilterOutcome out = filter.update({}, std::vector<std::pair<LocationId, double>>{}, graph);
  EXPECT_EQ(out.reason, RejectReason::kNoHypothesis);
  EXPECT_EQ(out.hypothesis, kNewPlace);
  EXPECT_EQ(out.score, 0.0);
  EXPECT_EQ(out.new_place_posterior, 1.0);
  EXPECT_EQ(filter.state().previous_score, 0.0);  // the next frame's ratio test cannot reject

  // All locations alike: the smallest id wins the tie.
  BayesFilter tie;
  out = tie.update({9, 4, 7}, std::vector<std::pair<LocationId, double>>{}, graph);
  EXPECT_EQ(out.hypothesis, 4);
  EXPECT_EQ(tie.posteriorOf(4), tie.posteriorOf(9));
}

TEST(BayesFilter, RejectsBadInputs) {
  BayesFilter filter;
  const LinkGraph graph;
  using Sims = std::vector<std::pair<LocationId, double>>;
  EXPECT_THROW(filter.update({1, 2}, Sims{{3, 0.5}}, graph), Error);  // not in WM
  EXPECT_THROW(filter.update({1, 2}, Sims{{1, 1.5}}, graph), Error);  // not a similarity
  EXPECT_THROW(filter.update({1, 1}, Sims{}, graph), Error);          // repeated id
  EXPECT_THROW(filter.restore({{{2, 0.5}, {1, 0.5}}, 0.0}), Error);
  EXPECT_THROW(filter.restore({{{1, std::nan("")}}, 0.0}), Error);
}

TEST(BayesFilter, RestoredStateContinuesBitIdentically) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  // Inputs drawn in advance so both runs see the very same frames.
  struct Frame {
    std::vector<LocationId> wm;
    std::vector<std::pair<LocationId, double>> sims;
  };
  std::vector<Frame> frames;
  LinkGraph graph;
  std::vector<LocationId> wm;
  for (LocationId t = 0; t < 160; ++t) {
    wm.push_back(t);
    graph.addNode(t);
    if (t > 0) graph.addLink(t - 1, t);
    if (t > 60 && t % 9 == 0) graph.addLink(t, t - 55);
    if (t % 13 == 0 && wm.size() > 8) wm.erase(wm.begin() + static_cast<long>(wm.size() / 3));
    Frame f{wm, {}};
    for (LocationId id : wm) {
      if (u(rng) < 0.25) f.sims.emplace_back(id, t > 80 && id + 60 == t ? 0.7 : 0.15 * u(rng));
    }
    frames.push_back(f);
  }
  BayesFilter uninterrupted;
  std::vector<FilterOutcome> reference;
  FilterState saved;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    if (k == 90) saved = uninterrupted.state();
    reference.push_back(uninterrupted.update(frames[k].wm, frames[k].sims, graph));
  }
  BayesFilter resumed;
  resumed.update(frames[0].wm, frames[0].sims, graph);  // unrelated history, then overwritten
  resumed.restore(saved);
  for (std::size_t k = 90; k < frames.size(); ++k) {
    const FilterOutcome out = resumed.update(frames[k].wm, frames[k].sims, graph);
    EXPECT_EQ(out.score, reference[k].score) << k;  // exact, not near
    EXPECT_EQ(out.hypothesis, reference[k].hypothesis) << k;
    EXPECT_EQ(out.hypothesis_posterior, reference[k].hypothesis_posterior) << k;
    EXPECT_EQ(out.reason, reference[k].reason) << k;
  }
  EXPECT_EQ(resumed.state(), uninterrupted.state());
  int accepted = 0;
  for (const auto& out : reference) accepted += out.accepted;
  EXPECT_GT(accepted, 0);  // the planted revisits make the run exercise the accept path
}

TEST(BayesFilterSettings, ValidateNamesEveryBadField) {
  EXPECT_NO_THROW(BayesFilterSettings{}.validate());
  BayesFilterSettings bad;
  bad.t_loop = -0.1;
  bad.prediction_sigma = -1.0;
  bad.loop_ratio = 1.5;
  try {
    bad.validate();
    FAIL() << "bad settings accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    const std::string message = e.what();
    EXPECT_NE(message.find("t_loop"), std::string::npos) << message;
    EXPECT_NE(message.find("prediction_sigma"), std::string::npos) << message;
    EXPECT_NE(message.find("loop_ratio"), std::string::npos) << message;
  }
  EXPECT_THROW(BayesFilter{bad}, Error);
}

}  // namespace
}  // namespace placedb
