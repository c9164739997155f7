// Localisation: an image against the stored locations of every tier, changing nothing in RAM or
// in the file.
//
// Candidates come from two searches: the bag-of-words similarity (eq. 5), and the place codes
// over every location, LTM included. The words cover STM and WM, and LTM too when the map's
// vocabulary fits kQueryWordBudget: the mapping dropped an LTM location's words from RAM, so a
// revisit was quantised to other words, but a read-only map can take them all back, and eq. 5
// over every location ranks a place far better than its code (the right location is among the
// first 15 codes for 94 % of lip6 frames). The codes rank each location by its centred cosine
// averaged over its traversal neighbours (place_index.h, place_neighbourhood.h), and when no
// candidate passes the check, further down that ranking before the answer is "unknown". Each
// candidate goes through the mapping's geometric check against its own stored keypoints, and
// so do the locations within two links of the best one that passes (again around a neighbour
// that beats it, until the best stays the same); the verdict is "known" when the best candidate
// passes it (the mapping's geometry rule), "unknown" when none does. A place never seen still
// finds look-alike candidates, but their matches do not agree on one epipolar geometry, so it
// is reported unknown instead of as its nearest look-alike.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <memory>
#include <set>

#include "features/image_conversion.h"
#include "map/map_impl.h"
#include "map/option_mapping.h"

namespace placedb {
namespace {

// Candidates taken from each search, at least: enough for the check to find the place when the
// best-looking location is a near neighbour of the right one. Place codes are coarser than the
// words: on lip6_outdoor's half map with 361 of 531 locations in LTM, the right location ranks
// within the first 15 codes where it misses the first 5 (bench/quality/README.md).
constexpr std::size_t kWordCandidates = 5;
constexpr std::size_t kCodeCandidates = 15;
// When none of the candidates passes, the code ranking is checked further, a batch of
// kCodeCandidates at a time, up to this many batches in all: a query that finds nothing costs
// up to 4 times the checks before it answers "unknown". On the 100k-frame scale map, the
// frames whose location ranked 16th to 55th were answered unknown with one batch.
constexpr std::size_t kCodeBatches = 4;
// Links around the best verified candidate whose locations are checked too.
constexpr int kNeighbourDepth = 2;
// Words a localisation map may hold in RAM (64 floats each: 256 MB, plus the kd-forest's
// nodes) for its LTM locations to be searched by their words. The file keeps every word ever
// made, so its largest word id bounds them; a larger map searches LTM by place codes only.
constexpr std::int64_t kQueryWordBudget = 1000000;

}  // namespace

const char* toString(QueryVerdict verdict) {
  switch (verdict) {
    case QueryVerdict::kKnown:
      return "known";
    case QueryVerdict::kUnknown:
      return "unknown";
    case QueryVerdict::kUnverified:
      return "unverified";
  }
  return "unknown";
}

void MapImpl::loadLtmWords() {
  ltm_words_.emplace();
  if (tiers_->ltmSize() == 0) return;
  const auto max_word = store_->maxWordId();
  if (!max_word || *max_word >= kQueryWordBudget) return;
  const std::vector<std::int64_t> ltm = tiers_->ltm();
  auto words = store_->loadWordIds(ltm);
  std::vector<std::int64_t> missing;
  for (std::int64_t id : ltm) {
    for (std::int64_t word : words[id])
      if (!vocabulary_->contains(word)) missing.push_back(word);
    ltm_words_->add(id, Signature::fromWords(std::move(words[id])));
  }
  // Every LTM location's words: walking the words table in id order reads less than every
  // location's own row would.
  restoreWords(std::move(missing), {});
}

void MapImpl::loadPlaceNeighbourhood() {
  std::vector<std::pair<std::int64_t, std::int64_t>> links;
  for (const auto& l : store_->linksOfType(storage::LinkType::kNeighbour))
    links.emplace_back(l.location_a, l.location_b);
  place_neighbourhood_.emplace(places_, links);
}

QueryResult MapImpl::query(const cv::Mat& image, std::size_t top_k) {
  // A mapping map's vocabulary grows with every frame; a read-only one on the same file (SQLite
  // lets it read while the writer maps) answers from the last committed frame.
  if (mode_ != Mode::kLocalisation)
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("{}: query() needs the map opened read-only (localisation); to "
                            "localise against a map being built, open a second, read-only map "
                            "on the same file",
                            store_->path()));
  const auto start = std::chrono::steady_clock::now();
  QueryResult result;
  Features features = extractor_->extract(toGrey8(image));
  result.feature_count = features.size();
  GeometricCheckSettings geometry = toGeometricCheckSettings(options_);
  geometry.exhaustive = true;  // candidates are ranked by their inliers
  const bool check_on = geometricCheckOn(options_);
  result.verdict = check_on ? QueryVerdict::kUnknown : QueryVerdict::kUnverified;
  if (features.size() == 0 || vocabulary_->size() == 0) return result;

  // Nearest words only: in localisation mode the vocabulary is fixed, so nothing is created.
  if (!vocabulary_->options().fixed)
    throw Error(ErrorCode::kInternal, "query() needs a map opened in localisation mode");
  if (!ltm_words_) loadLtmWords();
  vocab::Quantization q = vocabulary_->quantize(features.descriptors, 0);
  std::vector<WordId> words;
  for (std::int64_t id : q.word_of_feature)
    if (id >= 0) words.push_back(id);
  Signature signature = Signature::fromWords(std::move(words));

  const std::size_t wanted = std::max(top_k, kWordCandidates);
  const std::size_t batch = std::max(top_k, kCodeCandidates);  // code candidates per round
  std::map<LocationId, QueryMatch> candidates;
  auto sims = index_.similarities(signature);
  const auto ltm_sims = ltm_words_->similarities(signature);
  sims.insert(sims.end(), ltm_sims.begin(), ltm_sims.end());
  result.searched = sims.size();
  // Equal similarities: the smaller location id first, whichever tier holds it.
  std::sort(sims.begin(), sims.end(), [](const auto& a, const auto& b) {
    return a.similarity != b.similarity ? a.similarity > b.similarity : a.location < b.location;
  });
  for (std::size_t i = 0; i < sims.size(); ++i) {
    if (i < wanted) candidates[sims[i].location].location_id = sims[i].location;
    auto it = candidates.find(sims[i].location);
    if (it != candidates.end()) it->second.similarity = sims[i].similarity;
  }
  std::vector<std::int8_t> code;
  std::vector<LocationId> further;  // code matches below the first batch, best first
  if (coder_ && features.descriptors.type() == CV_32F) {
    code = coder_->encode(features.descriptors);
    result.searched = std::max(result.searched, places_.size());
    // Ranked by neighbourhood, more than one batch deep: the batches after the first are
    // checked only when nothing in the first passes.
    if (!place_neighbourhood_) loadPlaceNeighbourhood();
    const auto ranked =
        place_neighbourhood_->search(places_.centredSimilarities(code), batch * kCodeBatches,
                                     [this](LocationId id) { return tiers_->contains(id); });
    for (std::size_t i = 0; i < ranked.size(); ++i) {
      if (i < batch)
        candidates[ranked[i].location].location_id = ranked[i].location;
      else
        further.push_back(ranked[i].location);
    }
  }

  // A candidate's entry: where it is held and how like the frame its code is.
  const auto enter = [&](LocationId id) {
    QueryMatch& match = candidates[id];
    match.location_id = id;
    match.tier = tiers_->contains(id) ? tiers_->tierOf(id) : Tier::kLtm;
    if (!code.empty()) match.code_similarity = places_.similarity(code, id);
  };
  std::vector<LocationId> ids;
  for (const auto& [id, match] : candidates) ids.push_back(id);
  for (LocationId id : ids) enter(id);

  if (check_on) {
    GeometricView view;
    view.descriptors = features.descriptors;
    for (const auto& k : features.keypoints) view.points.emplace_back(k.x, k.y);
    view.image_size = features.image_size;
    view.words = q.word_of_feature;
    view.codes = std::make_shared<const DescriptorCodes>(
        quantiseDescriptors(features.descriptors, kQueryCodeLevels));
    auto check = [&](const std::vector<LocationId>& which) {
      // A verdict chooses among every place checked so far: their false alarms all count.
      if (options_.geometry_count_candidates)
        geometry.tests = std::max(1, static_cast<int>(candidates.size()));
      for (LocationId id : which) {
        // Read from the file, not the mapping's cache: a query may touch any location.
        const CachedKeypoints keypoints = loadKeypoints(id);
        if (keypoints.points.empty()) continue;
        const GeometricResult g = checkGeometry(view, viewOf(keypoints), geometry);
        QueryMatch& match = candidates[id];
        // Eq. 5 from the stored words, so that locations of every tier compare alike.
        match.similarity = similarity(signature, Signature::fromWords(keypoints.words));
        match.inliers = g.inliers;
        match.verified = g.passed;
        if (g.passed) match.pose = closurePose(id, g, &match.no_pose_reason);
        // A place of several frames is ranked by the view closer to the query's, as mapping
        // names it (latest_view.h); its pose stays in its first frame's camera.
        if (const std::optional<GeometricView> latest = g.passed ? latestView(id) : std::nullopt) {
          const GeometricResult l = checkGeometry(view, *latest, geometry);
          if (l.passed) match.inliers = std::max(match.inliers, l.inliers);
        }
        ++result.checked;
      }
    };
    check(ids);
    // Nothing passed: before answering "unknown", the next batch down the code ranking.
    for (std::size_t from = 0; from < further.size(); from += batch) {
      if (std::any_of(candidates.begin(), candidates.end(),
                      [](const auto& c) { return c.second.verified; }))
        break;
      std::vector<LocationId> next;
      for (std::size_t i = from; i < std::min(further.size(), from + batch); ++i) {
        const LocationId id = further[i];
        if (candidates.count(id)) continue;
        enter(id);
        next.push_back(id);
      }
      check(next);
    }
    // The searches rank whole images; the best verified place's graph neighbours (any tier)
    // often see the query's viewpoint better still, as the filter's neighbours do in mapping.
    // Climbs: when a neighbour beats the best, its own neighbourhood is checked in turn.
    std::set<LocationId> expanded;
    for (;;) {
      const QueryMatch* best = nullptr;
      for (const auto& [id, match] : candidates)
        if (match.verified && (!best || match.inliers > best->inliers)) best = &match;
      if (!best || !expanded.insert(best->location_id).second) break;
      std::vector<LocationId> around;
      std::vector<LocationId> frontier{best->location_id};
      for (int depth = 0; depth < kNeighbourDepth; ++depth) {
        std::vector<LocationId> next;
        for (LocationId id : frontier)
          for (const auto& l : store_->links(id)) {
            const LocationId other = l.location_a == id ? l.location_b : l.location_a;
            if (candidates.count(other) || std::count(around.begin(), around.end(), other))
              continue;
            around.push_back(other);
            next.push_back(other);
          }
        frontier = std::move(next);
      }
      for (LocationId id : around) enter(id);
      check(around);
    }
  }

  std::vector<QueryMatch> ranked;
  for (auto& [id, match] : candidates) ranked.push_back(std::move(match));
  std::sort(ranked.begin(), ranked.end(), [](const QueryMatch& a, const QueryMatch& b) {
    if (a.verified != b.verified) return a.verified;
    if (a.verified && a.inliers != b.inliers) return a.inliers > b.inliers;
    // Place codes compare every tier alike; eq. 5 exists only for locations in RAM.
    if (a.code_similarity != b.code_similarity) return a.code_similarity > b.code_similarity;
    if (a.similarity != b.similarity) return a.similarity > b.similarity;
    return a.location_id < b.location_id;
  });
  if (ranked.size() > top_k) ranked.resize(top_k);
  if (!ranked.empty() && ranked.front().verified) result.verdict = QueryVerdict::kKnown;
  for (auto& m : ranked) m.frames = framesOf(m.location_id);
  result.matches = std::move(ranked);
  result.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace placedb
