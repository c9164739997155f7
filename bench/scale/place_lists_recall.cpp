// The place-code search through the inverted file (memory/place_lists.h) against the exact
// scan, on the codes of a map: top-k recall (the share of the exact k best the lists find too)
// and the time of each search. With --hnsw, the same for hnswlib's graph over the same codes.
//
//   placedb_place_lists_recall MAP [--codes N] [--from F] [--list-rows R] [--probe-share S]
//                              [--queries Q] [--k K] [--hnsw M:EF_CONSTRUCTION:EF]
//
// The map holds N codes (--codes: its first N by location id, a smaller map of the same run).
// Each query is the code of one of Q locations spread over ids from F on, searched among the
// locations made more than 20 before it (what the frame that made it searched: its STM excluded
// and no later place). See bench/scale/README.md.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <fmt/core.h>

#if __has_include(<hnswlib/hnswlib.h>)
#include <hnswlib/hnswlib.h>
#define PLACEDB_HAVE_HNSWLIB 1
#endif

#include "memory/place_index.h"
#include "placedb/storage/map_store.h"

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

struct Tally {
  double found = 0, wanted = 0, ms = 0;
  int searches = 0;
  void add(const std::vector<std::int64_t>& exact, const std::vector<std::int64_t>& got, double t) {
    const std::set<std::int64_t> g(got.begin(), got.end());
    for (std::int64_t id : exact) found += g.count(id);
    wanted += double(exact.size());
    ms += t;
    ++searches;
  }
  void print(const char* name, std::size_t k) const {
    fmt::print("{:<28} top-{} recall {:.4f} ({:.0f}/{:.0f})", name, k,
               wanted > 0 ? found / wanted : 1.0, found, wanted);
    if (ms > 0) fmt::print(", {:.3f} ms a search", ms / std::max(1, searches));
    fmt::print("\n");
  }
};

}  // namespace

int main(int argc, char** argv) {
  const bool help = argc == 2 && (std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h");
  if (argc < 2 || help) {
    fmt::print(help ? stdout : stderr,
               "usage: {} MAP [--codes N] [--from F] [--list-rows R] [--probe-share S] "
               "[--queries Q] [--k K] [--hnsw M:EFC:EF]\n"
               "Top-k recall and time of the place-code lists (and hnswlib's graph, when built\n"
               "with it) against the exact scan, over MAP's place codes; bench/scale/README.md.\n",
               argv[0]);
    return help ? 0 : 2;
  }
  std::size_t codes_wanted = 0, from = 16384, list_rows = placedb::PlaceIndex::kListRows,
              probe_share = placedb::PlaceIndex::kProbeShare, queries = 2000, k = 5;
  std::string hnsw;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    const std::size_t v = std::strtoull(argv[i + 1], nullptr, 10);
    if (flag == "--codes")
      codes_wanted = v;
    else if (flag == "--from")
      from = v;
    else if (flag == "--list-rows")
      list_rows = v;
    else if (flag == "--probe-share")
      probe_share = v;
    else if (flag == "--queries")
      queries = v;
    else if (flag == "--k")
      k = v;
    else if (flag == "--hnsw")
      hnsw = argv[i + 1];
    else {
      fmt::print(stderr, "unknown flag {}\n", flag);
      return 2;
    }
  }
  std::vector<placedb::storage::PlaceCodeRecord> records;  // by location id
  try {
    records = placedb::storage::openMapStore(argv[1], placedb::storage::OpenMode::kReadOnly)
                  ->placeCodes();
  } catch (const std::exception& e) {
    fmt::print(stderr, "placedb_place_lists_recall: {}\n", e.what());
    return 1;
  }
  if (codes_wanted > 0 && codes_wanted < records.size()) records.resize(codes_wanted);
  placedb::PlaceIndex exact, lists;
  lists.setListsFrom(from, list_rows, probe_share);
  for (const auto& r : records) {
    exact.add(r.location_id, r.code);
    lists.add(r.location_id, r.code);
  }
  const std::size_t n = records.size();
  if (n <= from) {
    fmt::print(stderr, "{} codes, not above --from {}\n", n, from);
    return 2;
  }
  std::vector<std::size_t> asked;
  // The map's last codes: each searched among nearly every code, as the frame that made it was.
  for (std::size_t q = n - std::min(queries, n - from); q < n; ++q) asked.push_back(q);

  // The first search trains the lists: timed on its own.
  auto t = Clock::now();
  const auto none = [](std::int64_t) { return true; };
  lists.search(records[asked[0]].code, k, none);
  fmt::print(
      "{} codes; lists trained on the first {} in {:.0f} ms (and filled): {} lists, {} "
      "probed a search\n",
      n, from, msSince(t), lists.lists(), lists.probes());

  {
    const placedb::PlaceLists& l = *lists.placeLists();
    std::size_t largest = 0;
    for (std::size_t i = 0; i < l.lists(); ++i) largest = std::max(largest, l.rows(i).size());
    double scanned = 0;
    for (std::size_t q : asked)
      for (std::size_t i : l.nearest(records[q].code.data(), lists.probes()))
        scanned += double(l.rows(i).size());
    fmt::print("largest list {} codes; a search scans {:.0f} codes ({:.1f} %) on average\n",
               largest, scanned / double(asked.size()), 100 * scanned / double(asked.size() * n));
  }
  Tally tally_lists, tally_exact;
  std::vector<std::vector<std::int64_t>> truth;
  struct Answer {
    double best;
    std::vector<std::int64_t> exact, lists;
  };
  std::vector<Answer> by_best;
  for (std::size_t q : asked) {
    const std::int64_t id = records[q].location_id;
    const auto admit = [id](std::int64_t other) { return other < id - 20; };
    t = Clock::now();
    const auto e = exact.search(records[q].code, k, admit);
    const double exact_ms = msSince(t);
    t = Clock::now();
    const auto l = lists.search(records[q].code, k, admit);
    const double lists_ms = msSince(t);
    std::vector<std::int64_t> e_ids, l_ids;
    for (const auto& m : e) e_ids.push_back(m.location);
    for (const auto& m : l) l_ids.push_back(m.location);
    tally_exact.add(e_ids, e_ids, exact_ms);
    tally_lists.add(e_ids, l_ids, lists_ms);
    if (!e.empty()) by_best.push_back({e[0].similarity, e_ids, l_ids});
    truth.push_back(std::move(e_ids));
  }
  tally_exact.print("exact scan (threads 1)", k);
  tally_lists.print("inverted file", k);
  // The queries whose best exact match is nearest (a revisit's, likely) against the rest.
  std::sort(by_best.begin(), by_best.end(),
            [](const Answer& a, const Answer& b) { return a.best > b.best; });
  Tally closest, others;
  for (std::size_t i = 0; i < by_best.size(); ++i)
    (i < by_best.size() / 4 ? closest : others).add(by_best[i].exact, by_best[i].lists, 0);
  closest.print("  quarter, best cosine highest", k);
  others.print("  the other three quarters", k);

#if defined(PLACEDB_HAVE_HNSWLIB)
  if (!hnsw.empty()) {
    int m = 16, efc = 200, ef = 64;
    std::sscanf(hnsw.c_str(), "%d:%d:%d", &m, &efc, &ef);
    const std::size_t dim = records[0].code.size();
    hnswlib::InnerProductSpace space(dim);
    hnswlib::HierarchicalNSW<float> graph(&space, n, m, efc);
    const auto unit = [dim](const std::vector<std::int8_t>& c) {
      std::vector<float> v(c.begin(), c.end());
      double s = 0;
      for (float x : v) s += double(x) * x;
      const float inv = s > 0 ? float(1 / std::sqrt(s)) : 0.f;
      for (float& x : v) x *= inv;
      (void)dim;
      return v;
    };
    t = Clock::now();
    for (const auto& r : records) graph.addPoint(unit(r.code).data(), std::size_t(r.location_id));
    fmt::print("hnswlib M {} ef_construction {}: built in {:.0f} ms\n", m, efc, msSince(t));
    graph.setEf(std::size_t(std::max<int>(ef, int(4 * k))));
    // Debian's hnswlib (0.6) has no filter: the search asks 4k and keeps the first k admitted,
    // as the engine would have to (STM is never a match).
    Tally tally_hnsw;
    for (std::size_t i = 0; i < asked.size(); ++i) {
      const auto& r = records[asked[i]];
      const auto v = unit(r.code);
      t = Clock::now();
      auto found = graph.searchKnn(v.data(), 4 * k);
      std::vector<std::pair<float, std::int64_t>> ranked;
      for (; !found.empty(); found.pop())
        ranked.emplace_back(found.top().first, std::int64_t(found.top().second));
      std::sort(ranked.begin(), ranked.end());  // distance 1 - cosine, nearest first
      std::vector<std::int64_t> ids;
      for (const auto& [distance, id] : ranked)
        if (id < r.location_id - 20 && ids.size() < k) ids.push_back(id);
      const double ms = msSince(t);
      tally_hnsw.add(truth[i], ids, ms);
    }
    tally_hnsw.print(fmt::format("hnswlib ef {}", ef).c_str(), k);
  }
#else
  if (!hnsw.empty()) fmt::print("hnswlib headers not found at build time\n");
#endif
  return 0;
}
