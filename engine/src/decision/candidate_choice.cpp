#include "decision/candidate_choice.h"

#include <algorithm>
#include <set>
#include <utility>

namespace placedb {

std::vector<LocationId> orderCandidates(const CandidateSources& sources,
                                        const std::function<double(LocationId)>& similarity) {
  std::vector<LocationId> ordered;
  if (sources.hypothesis == kNewPlace) return ordered;
  ordered.push_back(sources.hypothesis);
  std::set<LocationId> seen{sources.hypothesis};
  std::vector<std::pair<double, LocationId>> others;
  for (const auto* list :
       {&sources.around, &sources.most_similar, &sources.searched_back, &sources.near_last_closure})
    for (LocationId c : *list)
      if (seen.insert(c).second) others.emplace_back(-similarity(c), c);
  std::sort(others.begin(), others.end());
  for (const auto& [negated, c] : others) ordered.push_back(c);
  return ordered;
}

CandidateChoice chooseCandidate(const std::vector<LocationId>& ordered,
                                const std::vector<LocationId>& near, GeometryRule rule,
                                const CandidateCheck& check,
                                const std::function<bool(const GeometricResult&)>& passes_relaxed) {
  CandidateChoice choice;
  std::optional<GeometricResult> best_near;
  LocationId near_location = kNewPlace;
  const auto isNear = [&near](LocationId c) {
    return std::binary_search(near.begin(), near.end(), c);
  };
  const auto run = [&](LocationId c) {
    std::optional<GeometricResult> g = check(c);
    if (!g) return g;
    ++choice.checked;
    if (isNear(c) && (!best_near || strongerThan(*g, *best_near, rule))) {
      best_near = g;
      near_location = c;
    }
    return g;
  };

  std::size_t next = 0;
  while (next < ordered.size()) {
    const LocationId c = ordered[next++];
    const std::optional<GeometricResult> g = run(c);
    if (!g) continue;
    if (!choice.result || strongerThan(*g, *choice.result, rule)) {
      choice.result = g;
      choice.location = c;
    }
    if (g->passed) break;
  }
  choice.passed = choice.result && choice.result->passed;

  if (choice.passed && !near.empty() && !isNear(choice.location)) {
    // A jump: the continuation gets its chance before it is given up.
    for (; next < ordered.size(); ++next)
      if (isNear(ordered[next])) run(ordered[next]);
    if (best_near && (best_near->passed || passes_relaxed(*best_near)) &&
        !strongerThan(*choice.result, *best_near, rule)) {
      choice.location = near_location;
      choice.result = best_near;
      choice.temporal = !best_near->passed;
    }
  } else if (!choice.passed && best_near && passes_relaxed(*best_near)) {
    // Too weak for a place on its own, not for one that continues the last closure.
    choice.location = near_location;
    choice.result = best_near;
    choice.passed = true;
    choice.temporal = true;
  }
  return choice;
}

}  // namespace placedb
