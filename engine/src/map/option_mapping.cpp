#include "map/option_mapping.h"

namespace placedb {

FeatureOptions toFeatureOptions(const Options& o) {
  FeatureOptions f;
  f.extractor = toString(o.extractor);
  f.hessian_threshold = o.hessian_threshold;
  f.octaves = o.octaves;
  f.intervals = o.intervals;
  f.upright = o.upright;
  f.max_features = o.max_features;
  f.feature_target = o.feature_target;
  f.feature_retry = o.feature_retry;
  f.min_response = static_cast<float>(o.min_response);
  f.threads = o.threads;
  return f;
}

vocab::VocabularyOptions toVocabularyOptions(const Options& o) {
  vocab::VocabularyOptions v;
  v.rule = o.word_rule;
  v.unit = o.distance_unit;
  v.t_nndr = static_cast<float>(o.t_nndr);
  v.t_nd1 = static_cast<float>(o.t_nd1);
  v.t_nd2 = static_cast<float>(o.t_nd2);
  v.kd_trees = o.kd_trees;
  v.checks = o.kd_checks;
  v.threads = o.threads;
  return v;
}

BayesFilterSettings toFilterSettings(const Options& o) {
  BayesFilterSettings s;
  s.prediction_sigma = o.prediction_sigma;
  s.prediction_links = o.prediction_links;
  s.rule = o.decision_rule;
  s.t_loop = o.t_loop;
  s.loop_ratio = o.loop_ratio;
  return s;
}

MemorySettings toMemorySettings(const Options& o) {
  MemorySettings m;
  m.stm_size = o.stm_size;
  m.wm_max = o.wm_max;
  m.time_limit_s = o.t_time_ms / 1000.0;
  m.time_floor = o.wm_min;
  m.immune_newest_count = o.wm_immune_newest;
  m.immune_newest_ratio = o.wm_recent_ratio;
  m.max_retrieved = o.max_retrieved;
  return m;
}

GeometricCheckSettings toGeometricCheckSettings(const Options& o) {
  GeometricCheckSettings g;
  g.rule = o.geometry_rule;
  g.max_nfa = o.geometry_max_nfa;
  g.min_inliers = o.geometry_min_inliers;
  g.min_overlap = o.geometry_min_overlap;
  g.max_error_px = o.geometry_max_error_px;
  g.max_error_diagonal = o.geometry_max_error_diagonal;
  g.match_ratio = o.geometry_match_ratio;
  g.count_max_nfa = o.geometry_count_candidates ? 1.0 : 0.0;
  return g;
}

RunSettings toRunSettings(const Options& o) {
  RunSettings s;
  s.radius = o.temporal_radius;
  s.max_gap = o.temporal_max_gap;
  return s;
}

bool geometricCheckOn(const Options& o) {
  const bool count = o.geometry_rule != GeometryRule::kNfa && o.geometry_min_inliers > 0;
  const bool chance = o.geometry_rule != GeometryRule::kInliers && o.geometry_max_nfa > 0;
  return count || chance;
}

}  // namespace placedb
