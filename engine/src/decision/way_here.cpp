#include "decision/way_here.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace placedb {

std::size_t surroundingsEnd(std::size_t size, const Unrelated& unrelated) {
  for (std::size_t i = 0; i + 1 < size; ++i)
    if (unrelated(i) && unrelated(i + 1)) return i;
  return size;
}

std::size_t placeSurroundingsBegin(std::size_t size, std::size_t end, const Unrelated& unrelated) {
  for (std::size_t j = size; j-- > end + 2;)
    if (unrelated(j) && unrelated(j - 1)) return j;
  return end + 1;
}

std::vector<LocationId> mostSimilar(const std::vector<LocationId>& places,
                                    const std::vector<LocationSimilarity>& similarities,
                                    int count) {
  std::unordered_map<LocationId, double> similarity;
  similarity.reserve(similarities.size());
  for (const auto& s : similarities) similarity.emplace(s.location, s.similarity);
  struct Ranked {
    LocationId location;
    double similarity;
  };
  std::vector<Ranked> ranked;
  ranked.reserve(places.size());
  for (LocationId id : places) {
    const auto it = similarity.find(id);
    ranked.push_back({id, it == similarity.end() ? 0.0 : it->second});
  }
  const auto k = std::min(ranked.size(), static_cast<std::size_t>(std::max(0, count)));
  std::partial_sort(ranked.begin(), ranked.begin() + static_cast<std::ptrdiff_t>(k), ranked.end(),
                    [](const Ranked& a, const Ranked& b) {
                      return a.similarity != b.similarity ? a.similarity > b.similarity
                                                          : a.location > b.location;
                    });
  std::vector<LocationId> out;
  out.reserve(k);
  for (std::size_t i = 0; i < k; ++i) out.push_back(ranked[i].location);
  return out;
}

bool withinRefutation(const RefutedPlace& refuted, std::int64_t frame, std::int64_t session,
                      int max_gap) {
  return refuted.location != 0 && refuted.session == session && frame > refuted.frame &&
         frame - refuted.frame <= max_gap;
}

double impostorTries(int rank, int uniform) {
  if (uniform > 0) return uniform;
  const double j = std::max(1, rank);
  return j * (j + 1);
}

double countedLog10Nfa(double log10_nfa, double tries) {
  return log10_nfa + std::log10(std::max(1.0, tries));
}

bool refutes(double accepted_log10_nfa, double impostor_log10_nfa, double tries, double max_nfa,
             bool passing_refutes) {
  const double bar = std::log10(max_nfa);
  const double impostor = countedLog10Nfa(impostor_log10_nfa, tries);
  if (passing_refutes && impostor <= bar) return true;
  return accepted_log10_nfa - std::min(0.0, impostor) > bar;
}

}  // namespace placedb
