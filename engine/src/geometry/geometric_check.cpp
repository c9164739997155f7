#include "geometry/geometric_check.h"

#include "geometry/epipolar_fit.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace placedb {
std::vector<std::uint8_t> encodeDescriptors(const cv::Mat& descriptors) {
  const int dim = descriptors.cols;
  std::vector<std::uint8_t> out;
  out.reserve(static_cast<std::size_t>(descriptors.rows) * (sizeof(float) + dim));
  for (int r = 0; r < descriptors.rows; ++r) {
    const float* row = descriptors.ptr<float>(r);
    float scale = 0.f;
    for (int c = 0; c < dim; ++c) scale = std::max(scale, std::abs(row[c]));
    std::uint8_t scale_bytes[sizeof(float)];
    std::memcpy(scale_bytes, &scale, sizeof(float));
    out.insert(out.end(), scale_bytes, scale_bytes + sizeof(float));
    for (int c = 0; c < dim; ++c) {
      const float v = scale > 0.f ? std::round(row[c] / scale * 127.f) : 0.f;
      out.push_back(static_cast<std::uint8_t>(static_cast<std::int8_t>(v)));
    }
  }
  return out;
}

cv::Mat decodeDescriptors(const std::vector<std::uint8_t>& bytes, int dim) {
  const std::size_t row_bytes = sizeof(float) + static_cast<std::size_t>(dim);
  if (dim <= 0 || bytes.size() % row_bytes != 0) return cv::Mat();
  const int rows = static_cast<int>(bytes.size() / row_bytes);
  cv::Mat out(rows, dim, CV_32F);
  for (int r = 0; r < rows; ++r) {
    const std::uint8_t* in = bytes.data() + static_cast<std::size_t>(r) * row_bytes;
    float scale = 0.f;
    std::memcpy(&scale, in, sizeof(float));
    float* row = out.ptr<float>(r);
    for (int c = 0; c < dim; ++c)
      row[c] = static_cast<float>(static_cast<std::int8_t>(in[sizeof(float) + c])) * scale / 127.f;
  }
  return out;
}

bool strongerThan(const GeometricResult& a, const GeometricResult& b, GeometryRule rule) {
  return rule == GeometryRule::kNfa ? a.log10_nfa < b.log10_nfa : a.inliers > b.inliers;
}

int minimumInliers(double overlap, int keypoints) {
  return static_cast<int>(std::ceil(overlap * keypoints - 1e-9));
}

double agreementDistance(const GeometricCheckSettings& settings, cv::Size image_size) {
  if (settings.max_error_diagonal <= 0 || image_size.width <= 0 || image_size.height <= 0)
    return settings.max_error_px;
  return std::min(settings.max_error_px,
                  settings.max_error_diagonal * std::hypot(image_size.width, image_size.height));
}

cv::Size2f keypointExtent(const std::vector<cv::Point2f>& points) {
  if (points.empty()) return {1.f, 1.f};
  float x0 = points[0].x, x1 = x0, y0 = points[0].y, y1 = y0;
  for (const auto& p : points) {
    x0 = std::min(x0, p.x);
    x1 = std::max(x1, p.x);
    y0 = std::min(y0, p.y);
    y1 = std::max(y1, p.y);
  }
  return {std::max(1.f, x1 - x0), std::max(1.f, y1 - y0)};
}

namespace {

struct Pairs {
  std::vector<cv::Point2f> a, b;
  std::vector<int> query_index, candidate_index;
  void add(const GeometricView& query, int qi, const GeometricView& candidate, int ci) {
    a.push_back(query.points[static_cast<std::size_t>(qi)]);
    b.push_back(candidate.points[static_cast<std::size_t>(ci)]);
    query_index.push_back(qi);
    candidate_index.push_back(ci);
  }
};

// Keypoints whose word occurs exactly once in the view, by word.
std::vector<std::pair<std::int64_t, int>> uniqueWords(const std::vector<std::int64_t>& words) {
  std::vector<std::pair<std::int64_t, int>> all;
  all.reserve(words.size());
  for (std::size_t i = 0; i < words.size(); ++i)
    if (words[i] >= 0) all.emplace_back(words[i], static_cast<int>(i));
  std::sort(all.begin(), all.end());
  std::vector<std::pair<std::int64_t, int>> unique;
  for (std::size_t i = 0; i < all.size(); ++i) {
    const bool repeated = (i > 0 && all[i - 1].first == all[i].first) ||
                          (i + 1 < all.size() && all[i + 1].first == all[i].first);
    if (!repeated) unique.push_back(all[i]);
  }
  return unique;
}

Pairs wordPairs(const GeometricView& query, const GeometricView& candidate) {
  Pairs pairs;
  if (query.words.size() != query.points.size() ||
      candidate.words.size() != candidate.points.size())
    return pairs;
  const auto q = uniqueWords(query.words), c = uniqueWords(candidate.words);
  for (std::size_t i = 0, j = 0; i < q.size() && j < c.size();) {
    if (q[i].first < c[j].first) {
      ++i;
    } else if (c[j].first < q[i].first) {
      ++j;
    } else {
      pairs.add(query, q[i++].second, candidate, c[j++].second);
    }
  }
  return pairs;
}

// Ratio-test matches, one per candidate keypoint (the closest: a repeated texture cannot pile
// its matches onto one point), most distinctive first, then the word pairs they miss.
Pairs descriptorPairs(const GeometricView& query, const GeometricView& candidate,
                      const Pairs& words, double ratio) {
  Pairs pairs;
  DescriptorSide q_side{&query.descriptors, query.codes.get()};
  DescriptorSide c_side{&candidate.descriptors, candidate.codes.get()};
  if (q_side.rows() < 2 || c_side.rows() < 2) return words;
  // Codes for a side that came without them (a caller's own view, word descriptors).
  DescriptorCodes q_codes, c_codes;
  if (!q_side.codes) {
    q_codes = quantiseDescriptors(query.descriptors, kQueryCodeLevels);
    q_side.codes = &q_codes;
  }
  if (!c_side.codes) {
    c_codes = quantiseDescriptors(candidate.descriptors, kCandidateCodeLevels);
    c_side.codes = &c_codes;
  }
  struct Kept {
    int query, candidate;
    float distance, ratio;
  };
  // On this thread: a parallel matcher waits for pool threads on a busy machine longer than
  // the work takes.
  std::vector<Kept> kept;
  for (const RatioMatch& m : ratioMatches(q_side, c_side, static_cast<float>(ratio * ratio)))
    kept.push_back(
        {m.query, m.candidate, std::sqrt(m.d1), m.d2 > 0 ? std::sqrt(m.d1 / m.d2) : 0.f});
  std::sort(kept.begin(), kept.end(), [](const Kept& x, const Kept& y) {
    return x.candidate != y.candidate ? x.candidate < y.candidate : x.distance < y.distance;
  });
  std::vector<Kept> one;
  for (std::size_t k = 0; k < kept.size(); ++k)
    if (k == 0 || kept[k].candidate != kept[k - 1].candidate) one.push_back(kept[k]);
  std::stable_sort(one.begin(), one.end(),
                   [](const Kept& x, const Kept& y) { return x.ratio < y.ratio; });
  std::vector<char> query_used(query.points.size(), 0), candidate_used(candidate.points.size(), 0);
  for (const auto& k : one) {
    pairs.add(query, k.query, candidate, k.candidate);
    query_used[static_cast<std::size_t>(k.query)] = 1;
    candidate_used[static_cast<std::size_t>(k.candidate)] = 1;
  }
  for (std::size_t i = 0; i < words.a.size(); ++i) {
    const int qi = words.query_index[i], ci = words.candidate_index[i];
    if (query_used[static_cast<std::size_t>(qi)] || candidate_used[static_cast<std::size_t>(ci)])
      continue;
    pairs.add(query, qi, candidate, ci);
  }
  return pairs;
}

GeometricResult fit(const Pairs& pairs, cv::Size2f extent, int keypoints,
                    const GeometricCheckSettings& s, double confidence = 0) {
  GeometricResult r;
  r.keypoints = keypoints;
  r.matches = static_cast<int>(pairs.a.size());
  // The count a pass by the inliers rule needs (a 7-point model fits any 7 pairs: agreement
  // starts at the 8th), and the false alarms it may have over the frame's places.
  const int need = std::max(s.min_inliers, 8);
  const double tests = std::max(1, s.tests);
  const auto beyondChance = [&](double log10_nfa) {
    return s.count_max_nfa <= 0 || log10_nfa + std::log10(tests) <= std::log10(s.count_max_nfa);
  };
  EpipolarFitSettings fs;
  fs.iterations = s.iterations;
  fs.max_nfa = s.max_nfa / tests;
  fs.max_error_px = s.max_error_px;
  const bool count = s.rule != GeometryRule::kNfa, chance = s.rule != GeometryRule::kInliers;
  fs.stop_when_passed = chance && !s.exhaustive;
  fs.stop_at_inliers = count && !s.exhaustive ? need : 0;
  fs.stop_at_inliers_nfa = s.count_max_nfa > 0 ? s.count_max_nfa / tests : 0;
  fs.confidence = confidence;
  const EpipolarFit f = fitEpipolar(pairs.a, pairs.b, extent, fs);
  r.log10_nfa = f.log10_nfa;
  r.inliers = count ? f.most_within_max_error : f.inliers;
  const bool by_count = count && f.most_within_max_error >= need && beyondChance(f.log10_nfa);
  const bool by_chance =
      chance && f.passed && f.inliers >= minimumInliers(s.min_overlap, keypoints);
  r.passed = by_count || by_chance;
  for (int i : f.agreeing_pairs) {
    r.agreeing_query.push_back(pairs.a[static_cast<std::size_t>(i)]);
    r.agreeing_candidate.push_back(pairs.b[static_cast<std::size_t>(i)]);
  }
  if (!r.passed) {
    // Pairs that did not move (the same view again, as from a camera standing still) are a
    // degenerate case for a fundamental matrix: every skew-symmetric F fits them, so the 7-point
    // fit finds no single best model. They agree with the identity instead, which is judged by
    // the same rule, its chance level bounded by the epipolar one (a point near a given point is
    // rarer than a point near a given line).
    int still = 0;
    for (std::size_t i = 0; i < pairs.a.size(); ++i)
      if (cv::norm(pairs.a[i] - pairs.b[i]) <= s.max_error_px) ++still;
    const double log10_nfa =
        epipolarLog10Nfa(r.matches, still, s.max_error_px, extent, /*iterations=*/1);
    const bool still_by_count = count && still >= need && beyondChance(log10_nfa);
    const bool still_by_chance = chance && log10_nfa + std::log10(tests) <= std::log10(s.max_nfa) &&
                                 still >= std::max(8, minimumInliers(s.min_overlap, keypoints));
    if (still_by_count || still_by_chance) {
      r.inliers = still;
      r.log10_nfa = std::min(r.log10_nfa, log10_nfa);
      r.passed = true;
      r.still = true;
      r.agreeing_query.clear();
      r.agreeing_candidate.clear();
      for (std::size_t i = 0; i < pairs.a.size(); ++i)
        if (cv::norm(pairs.a[i] - pairs.b[i]) <= s.max_error_px) {
          r.agreeing_query.push_back(pairs.a[i]);
          r.agreeing_candidate.push_back(pairs.b[i]);
        }
    }
  }
  return r;
}

// The settings a check of `image_size`'s query runs with: the agreement distance of that size.
GeometricCheckSettings forQuery(const GeometricCheckSettings& settings, cv::Size image_size) {
  GeometricCheckSettings s = settings;
  s.max_error_px = agreementDistance(settings, image_size);
  return s;
}

int fewerKeypoints(const GeometricView& query, const GeometricView& candidate) {
  return static_cast<int>(std::min(query.points.size(), candidate.points.size()));
}

}  // namespace

GeometricResult checkGeometry(const GeometricView& query, const GeometricView& candidate,
                              const GeometricCheckSettings& settings) {
  const cv::Size2f extent = keypointExtent(candidate.points);
  const int keypoints = fewerKeypoints(query, candidate);
  const GeometricCheckSettings s = forQuery(settings, query.image_size);
  const Pairs words = wordPairs(query, candidate);
  GeometricResult by_words = fit(words, extent, keypoints, s);
  if (by_words.passed) by_words.from_words = true;
  if (by_words.passed && !s.exhaustive) return by_words;
  const GeometricResult by_descriptors =
      fit(descriptorPairs(query, candidate, words, s.match_ratio), extent, keypoints, s);
  return strongerThan(by_words, by_descriptors, settings.rule) ? by_words : by_descriptors;
}

GeometricResult compareGeometry(const GeometricView& query, const GeometricView& candidate,
                                const GeometricCheckSettings& settings, int at_least) {
  GeometricCheckSettings s = forQuery(settings, query.image_size);
  s.exhaustive = true;
  const Pairs pairs =
      descriptorPairs(query, candidate, wordPairs(query, candidate), settings.match_ratio);
  if (static_cast<int>(pairs.a.size()) < at_least) {
    GeometricResult bound;
    bound.matches = bound.inliers = static_cast<int>(pairs.a.size());
    bound.keypoints = fewerKeypoints(query, candidate);
    return bound;
  }
  return fit(pairs, keypointExtent(candidate.points), fewerKeypoints(query, candidate), s,
             kComparisonConfidence);
}

}  // namespace placedb
