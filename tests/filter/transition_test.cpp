// Link graph walks and the sparse banded prediction rows.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <random>

#include "filter/bayes_filter.h"
#include "filter/link_graph.h"
#include "filter/transition_model.h"
#include "placedb/error.h"

namespace placedb {
namespace {

LinkGraph chain(LocationId n) {
  LinkGraph g;
  g.addNode(0);
  for (LocationId id = 1; id < n; ++id) g.addLink(id - 1, id);
  return g;
}

double rowTotal(const PredictionRow& row) {
  double total = row.to_new_place;
  for (const auto& entry : row.to_locations) total += entry.second;
  return total;
}

TEST(LinkGraph, WalksUpToDepthThroughAllowedNodesOnly) {
  const LinkGraph g = chain(50);
  const auto reach = g.withinLinks(25, 16);
  ASSERT_EQ(reach.size(), 33u);
  for (const auto& [id, depth] : reach) EXPECT_EQ(depth, std::abs(static_cast<int>(id - 25)));
  EXPECT_EQ(reach.front().first, 9);
  EXPECT_EQ(reach.back().first, 41);

  // Node 20 refused: the walk cannot cross it, so the left side stops at 21.
  const auto blocked = g.withinLinks(25, 16, [](LocationId id) { return id != 20; });
  EXPECT_EQ(blocked.front().first, 21);
  EXPECT_EQ(blocked.back().first, 41);
  EXPECT_TRUE(g.withinLinks(25, 16, [](LocationId id) { return id != 25; }).empty());
  EXPECT_TRUE(g.withinLinks(999, 16).empty());
}

TEST(LinkGraph, LoopClosureLinksShortenDistances) {
  LinkGraph g = chain(50);
  g.addLink(0, 40);                        // a loop closure
  const auto reach = g.withinLinks(1, 3);  // 1 -> 0 -> 40: two links
  std::map<LocationId, int> depth(reach.begin(), reach.end());
  EXPECT_EQ(depth.at(40), 2);
  EXPECT_EQ(depth.at(39), 3);
  EXPECT_EQ(depth.at(41), 3);
  EXPECT_EQ(depth.count(38), 0u);
  g.removeNode(0);
  EXPECT_FALSE(g.hasLink(1, 0));
  EXPECT_TRUE(g.neighbours(40) == (std::vector<LocationId>{39, 41}));
  EXPECT_THROW(g.addLink(3, 3), Error);
}

TEST(LinkGraph, NeighbourWalkStaysOnItsTraversal) {
  // Two traversals of one street, 0..9 and 20..29, joined where 25 closed a loop on 5.
  LinkGraph g;
  for (LocationId id = 1; id < 10; ++id) g.addLink(id - 1, id);
  for (LocationId id = 21; id < 30; ++id) g.addLink(id - 1, id);
  g.addLink(25, 5, LinkKind::kLoopClosure);
  const auto ids = [](const std::vector<std::pair<LocationId, int>>& reach) {
    std::vector<LocationId> out;
    for (const auto& [id, depth] : reach) out.push_back(id);
    return out;
  };
  EXPECT_EQ(ids(g.withinLinks(25, 2, nullptr, LinkWalk::kNeighbourLinksOnly)),
            (std::vector<LocationId>{23, 24, 25, 26, 27}));
  EXPECT_EQ(ids(g.withinLinks(25, 1)), (std::vector<LocationId>{5, 24, 25, 26}));

  // The same pair linked again as neighbours is walked; a removed link is forgotten.
  g.addLink(5, 25, LinkKind::kNeighbour);
  EXPECT_EQ(ids(g.withinLinks(25, 1, nullptr, LinkWalk::kNeighbourLinksOnly)),
            (std::vector<LocationId>{5, 24, 25, 26}));
  g.removeLink(5, 25);
  g.addLink(5, 25, LinkKind::kLoopClosure);
  g.removeNode(5);
  g.addLink(5, 25);
  EXPECT_EQ(ids(g.withinLinks(25, 1, nullptr, LinkWalk::kNeighbourLinksOnly)),
            (std::vector<LocationId>{5, 24, 25, 26}));
}

TEST(TransitionModel, RowsSumToOneOnChainTreeAndRandomGraphs) {
  const BayesFilterSettings settings;
  const TransitionModel model(settings);
  std::vector<LinkGraph> graphs{chain(60)};
  LinkGraph tree;
  for (LocationId id = 1; id < 60; ++id) tree.addLink((id - 1) / 2, id);
  graphs.push_back(tree);
  std::mt19937_64 rng(7);
  LinkGraph random_graph = chain(60);
  std::uniform_int_distribution<LocationId> pick(0, 59);
  for (int k = 0; k < 40; ++k) {
    const LocationId a = pick(rng), b = pick(rng);
    if (a != b) random_graph.addLink(a, b);
  }
  graphs.push_back(random_graph);
  const auto all = [](LocationId) { return true; };
  const auto some = [](LocationId id) { return id % 7 != 3; };
  for (const LinkGraph& g : graphs) {
    for (LocationId j = 0; j < 60; ++j) {
      const PredictionRow row = model.fromLocation(j, g, all);
      EXPECT_NEAR(rowTotal(row), 1.0, 1e-12) << j;
      EXPECT_EQ(row.to_new_place, 0.1);
      if (some(j)) {
        const PredictionRow partial = model.fromLocation(j, g, some);
        EXPECT_NEAR(rowTotal(partial), 1.0, 1e-12) << j;
        for (const auto& entry : partial.to_locations) EXPECT_TRUE(some(entry.first));
      }
    }
  }
}

TEST(TransitionModel, ChainRowIsASymmetricGaussianBandOf16Links) {
  const TransitionModel model{BayesFilterSettings{}};
  const LinkGraph g = chain(200);
  const PredictionRow row = model.fromLocation(100, g, [](LocationId) { return true; });
  ASSERT_EQ(row.to_locations.size(), 33u);  // 100 - 16 .. 100 + 16: nothing beyond 16 links
  EXPECT_EQ(row.to_locations.front().first, 84);
  EXPECT_EQ(row.to_locations.back().first, 116);
  std::map<LocationId, double> p(row.to_locations.begin(), row.to_locations.end());
  // Independent normaliser: 1 + 2 * sum_{d=1..16} exp(-d^2 / (2 * 1.6^2)).
  double normaliser = 1.0;
  for (int d = 1; d <= 16; ++d) normaliser += 2.0 * std::exp(-d * d / (2.0 * 1.6 * 1.6));
  EXPECT_NEAR(p.at(100), 0.9 / normaliser, 1e-15);
  for (int d = 1; d <= 16; ++d) {
    EXPECT_EQ(p.at(100 + d), p.at(100 - d)) << d;  // symmetric, bit for bit
    EXPECT_NEAR(p.at(100 + d) / p.at(100), std::exp(-d * d / (2.0 * 1.6 * 1.6)), 1e-12);
    EXPECT_LT(p.at(100 + d), p.at(100 + d - 1));
  }
  // exp(-1/5.12) = 0.82262...: the first neighbour keeps about 82% of the centre's share.
  EXPECT_NEAR(p.at(101) / p.at(100), 0.8226, 1e-4);
}

TEST(TransitionModel, RowsStaySparseWhateverTheMapSize) {
  const TransitionModel model{BayesFilterSettings{}};
  const LinkGraph g = chain(20000);
  const auto all = [](LocationId) { return true; };
  EXPECT_EQ(model.fromLocation(10000, g, all).to_locations.size(), 33u);
  EXPECT_EQ(model.fromLocation(0, g, all).to_locations.size(), 17u);  // chain end: one side
  EXPECT_EQ(model.fromLocation(19999, g, all).to_locations.size(), 17u);
  LinkGraph isolated;
  const PredictionRow alone = model.fromLocation(5, isolated, all);  // not in the graph
  ASSERT_EQ(alone.to_locations.size(), 1u);
  EXPECT_EQ(alone.to_locations[0].second, 0.9);
}

TEST(TransitionModel, NewPlaceRowSpreadsEvenly) {
  const TransitionModel model{BayesFilterSettings{}};
  EXPECT_EQ(model.newPlaceStays(40), 0.9);
  EXPECT_NEAR(model.newPlaceToEachLocation(40), 0.1 / 40, 1e-18);
  EXPECT_EQ(model.newPlaceStays(0), 1.0);
  EXPECT_EQ(model.newPlaceToEachLocation(0), 0.0);
}

TEST(Prediction, FromNewPlaceOnly) {
  BayesFilter filter;
  const LinkGraph g = chain(20);
  std::vector<LocationId> wm(20);
  std::iota(wm.begin(), wm.end(), 0);
  const auto predicted = filter.predict(wm, g);  // empty state: prior p(-1) = 1
  ASSERT_EQ(predicted.size(), 21u);
  EXPECT_EQ(predicted[0].first, kNewPlace);
  EXPECT_NEAR(predicted[0].second, 0.9, 1e-15);
  for (std::size_t k = 1; k < predicted.size(); ++k) EXPECT_NEAR(predicted[k].second, 0.005, 1e-15);
}

TEST(Prediction, MassStaysWithin16LinksAndSumsToOne) {
  BayesFilter filter;
  const LinkGraph g = chain(100);
  std::vector<LocationId> wm(100);
  std::iota(wm.begin(), wm.end(), 0);
  filter.restore({{{kNewPlace, 0.0}, {50, 0.7}, {52, 0.3}}, 0.0});
  const auto predicted = filter.predict(wm, g);
  double total = 0.0;
  for (const auto& [id, p] : predicted) {
    total += p;
    if (id == kNewPlace) {
      EXPECT_NEAR(p, 0.1, 1e-15);
    } else if (id < 50 - 16 || id > 52 + 16) {
      EXPECT_EQ(p, 0.0) << id;
    } else {
      EXPECT_GT(p, 0.0) << id;
    }
  }
  EXPECT_NEAR(total, 1.0, 1e-12);

  // Random prior over a random graph restricted to part of it: still sums to one.
  std::mt19937_64 rng(3);
  LinkGraph rg = chain(300);
  std::uniform_int_distribution<LocationId> pick(0, 299);
  for (int k = 0; k < 100; ++k) {
    const LocationId a = pick(rng), b = pick(rng);
    if (a != b) rg.addLink(a, b);
  }
  std::vector<LocationId> partial_wm;
  FilterState state;
  state.posterior.emplace_back(kNewPlace, 0.25);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (LocationId id = 0; id < 300; ++id) {
    if (id % 5 == 1) continue;
    partial_wm.push_back(id);
    state.posterior.emplace_back(id, 0.75 * u(rng));
  }
  double mass = 0.0;
  for (std::size_t k = 1; k < state.posterior.size(); ++k) mass += state.posterior[k].second;
  for (std::size_t k = 1; k < state.posterior.size(); ++k) state.posterior[k].second *= 0.75 / mass;
  filter.restore(state);
  const auto fast = filter.predict(partial_wm, rg);
  total = 0.0;
  for (const auto& entry : fast) total += entry.second;
  EXPECT_NEAR(total, 1.0, 1e-12);

  // The filter's compact walk must give exactly what the reference rows give: p(-1|-1) p(-1) +
  // 0.1 sum p(j) for the new place, p(-1) (1 - 0.9)/M + sum_j p(j) row_j(i) for location i, with
  // the terms added in the same order (new place first, then j ascending).
  const TransitionModel model{BayesFilterSettings{}};
  const auto in_wm = [&partial_wm](LocationId id) {
    return std::binary_search(partial_wm.begin(), partial_wm.end(), id);
  };
  std::map<LocationId, double> reference;
  double location_mass = 0.0;
  for (std::size_t k = 1; k < state.posterior.size(); ++k)
    location_mass += state.posterior[k].second;
  reference[kNewPlace] = 0.9 * 0.25 + 0.1 * location_mass;
  for (LocationId id : partial_wm) reference[id] = 0.25 * ((1.0 - 0.9) / partial_wm.size());
  for (std::size_t k = 1; k < state.posterior.size(); ++k) {
    const auto& [j, mass] = state.posterior[k];
    for (const auto& [i, p] : model.fromLocation(j, rg, in_wm).to_locations)
      reference[i] += mass * p;
  }
  ASSERT_EQ(fast.size(), reference.size());
  for (const auto& [id, p] : fast) EXPECT_EQ(p, reference.at(id)) << id;
}

}  // namespace
}  // namespace placedb
