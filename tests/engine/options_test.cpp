// Options owns every setting: its default, its range and its text. These tests hold the
// components (features, vocabulary, filter, memory tiers, geometric check) to it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "map/option_mapping.h"
#include "placedb/error.h"
#include "placedb/options.h"

namespace placedb {
namespace {

std::string textOf(double v) {
  if (std::isfinite(v) && v == std::floor(v) && std::fabs(v) < 9e15)
    return std::to_string(static_cast<std::int64_t>(v));
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  return buffer;
}

bool isInteger(const Options::SettingInfo& s) {
  return s.default_value.find_first_not_of("-0123456789") == std::string::npos;
}

// Empty when every component takes `o`; otherwise the first component's refusal.
std::string componentRefusal(const Options& o) {
  const std::vector<std::function<void()>> checks = {
      [&] { validateFeatureOptions(toFeatureOptions(o)); },
      [&] { toVocabularyOptions(o).validate(); },
      [&] { toFilterSettings(o).validate(); },
      [&] { toMemorySettings(o).validate(); },
  };
  for (const auto& check : checks) {
    try {
      check();
    } catch (const Error& e) {
      return e.what();
    }
  }
  return "";
}

TEST(Options, EveryValueTheCatalogueAcceptsEveryComponentAccepts) {
  for (const auto& s : Options::catalogue()) {
    if (s.min > s.max) continue;  // a choice or a boolean: the enum holds only valid ones
    const double mid = isInteger(s) ? std::floor((s.min + s.max) / 2) : (s.min + s.max) / 2;
    for (double v : {s.min, mid, s.max}) {
      const std::string text = textOf(v);
      SCOPED_TRACE(s.key + "=" + text);
      Options o;
      ASSERT_NO_THROW(o = Options::fromSettings({{s.key, text}}));
      try {
        o.validate();
      } catch (const Error&) {
        continue;  // refused by a rule across settings (t_nd1 <= t_nd2), in the user's names
      }
      EXPECT_EQ(componentRefusal(o), "");
    }
  }
}

TEST(Options, ValuesOutsideTheRangeAreRefusedInTheUsersNames) {
  for (const auto& s : Options::catalogue()) {
    if (s.min > s.max) continue;
    std::vector<double> outside = {std::nextafter(s.min, -HUGE_VAL),
                                   std::nextafter(s.max, HUGE_VAL)};
    if (s.min - 1 != s.min) outside.push_back(s.min - 1);
    if (s.max + 1 != s.max) outside.push_back(s.max + 1);
    for (double v : outside) {
      const std::string text = textOf(v);
      SCOPED_TRACE(s.key + "=" + text);
      try {
        Options::fromSettings({{s.key, text}});
        ADD_FAILURE() << "accepted";
      } catch (const Error& e) {
        EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
        EXPECT_NE(std::string(e.what()).find(s.key), std::string::npos) << e.what();
      }
    }
  }
}

TEST(Options, RecentRatioOfOneIsRefusedAsWmRecentRatio) {
  try {
    Options::fromSettings({{"wm_recent_ratio", "1"}});
    FAIL() << "wm_recent_ratio=1 accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("wm_recent_ratio"), std::string::npos) << e.what();
  }
}

TEST(Options, ComponentDefaultsAreTheOptionsDefaults) {
  const Options o;
  const FeatureOptions f, fo = toFeatureOptions(o);
  EXPECT_EQ(f.extractor, fo.extractor);
  EXPECT_EQ(f.hessian_threshold, fo.hessian_threshold);
  EXPECT_EQ(f.octaves, fo.octaves);
  EXPECT_EQ(f.intervals, fo.intervals);
  EXPECT_EQ(f.upright, fo.upright);
  EXPECT_EQ(f.max_features, fo.max_features);
  EXPECT_EQ(f.min_response, fo.min_response);
  EXPECT_EQ(f.threads, fo.threads);

  const vocab::VocabularyOptions v, vo = toVocabularyOptions(o);
  EXPECT_EQ(v.rule, vo.rule);
  EXPECT_EQ(v.unit, vo.unit);
  EXPECT_EQ(v.t_nndr, vo.t_nndr);
  EXPECT_EQ(v.t_nd1, vo.t_nd1);
  EXPECT_EQ(v.t_nd2, vo.t_nd2);
  EXPECT_EQ(v.kd_trees, vo.kd_trees);
  EXPECT_EQ(v.checks, vo.checks);
  EXPECT_EQ(v.threads, vo.threads);

  const BayesFilterSettings b, bo = toFilterSettings(o);
  EXPECT_EQ(b.prediction_sigma, bo.prediction_sigma);
  EXPECT_EQ(b.prediction_links, bo.prediction_links);
  EXPECT_EQ(b.rule, bo.rule);
  EXPECT_EQ(b.t_loop, bo.t_loop);
  EXPECT_EQ(b.loop_ratio, bo.loop_ratio);

  const MemorySettings m, mo = toMemorySettings(o);
  EXPECT_EQ(m.stm_size, mo.stm_size);
  EXPECT_EQ(m.wm_max, mo.wm_max);
  EXPECT_EQ(m.time_limit_s, mo.time_limit_s);
  EXPECT_EQ(m.immune_newest_count, mo.immune_newest_count);
  EXPECT_EQ(m.immune_newest_ratio, mo.immune_newest_ratio);
  EXPECT_EQ(m.max_retrieved, mo.max_retrieved);

  const GeometricCheckSettings g, go = toGeometricCheckSettings(o);
  EXPECT_EQ(g.min_inliers, go.min_inliers);
  EXPECT_EQ(g.max_error_px, go.max_error_px);
  EXPECT_EQ(g.match_ratio, go.match_ratio);
}

TEST(Options, ChoicesKeepTheirTextAndRefuseAnyOther) {
  const auto defaults = Options().toSettings();
  EXPECT_EQ(defaults.at("extractor"), "surf");
  EXPECT_EQ(defaults.at("word_rule"), "greedy");
  EXPECT_EQ(defaults.at("distance_unit"), "squared");
  EXPECT_EQ(defaults.at("decision_rule"), "rtabmap");
  EXPECT_EQ(Options::paperPreset().toSettings().at("decision_rule"), "paper");
  const std::map<std::string, std::string> others = {{"extractor", "kaze"},
                                                     {"word_rule", "nndr"},
                                                     {"distance_unit", "euclidean"},
                                                     {"decision_rule", "paper"}};
  EXPECT_EQ(Options::fromSettings(others).toSettings(), [&] {
    auto expected = defaults;
    for (const auto& [key, value] : others) expected[key] = value;
    return expected;
  }());
  for (const auto& [key, misspelt] :
       std::map<std::string, std::string>{{"extractor", "SURF"},
                                          {"word_rule", "greedy "},
                                          {"distance_unit", "euclid"},
                                          {"decision_rule", "paper000"}}) {
    try {
      Options::fromSettings({{key, misspelt}});
      ADD_FAILURE() << key << "=" << misspelt << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
  Options cast;
  cast.word_rule = static_cast<WordRule>(7);
  EXPECT_THROW(cast.validate(), Error);
}

TEST(Options, StoredSettingsWithoutALaterSettingKeepWhatTheSessionRan) {
  // A session stored before feature_target existed searched every image once.
  auto stored = Options().toSettings();
  stored.erase("feature_target");
  EXPECT_EQ(Options::fromStoredSettings(stored).feature_target, 0);
  EXPECT_EQ(Options::fromSettings(stored).feature_target, Options().feature_target);
  stored["feature_target"] = "100";
  EXPECT_EQ(Options::fromStoredSettings(stored).feature_target, 100);
  // ... and one stored before feature_retry and geometry_max_error_diagonal searched again at
  // half the target and kept 3 px on any image.
  stored.erase("feature_retry");
  stored.erase("geometry_max_error_diagonal");
  EXPECT_EQ(Options::fromStoredSettings(stored).feature_retry, 0.5);
  EXPECT_EQ(Options::fromStoredSettings(stored).geometry_max_error_diagonal, 0.0);
  EXPECT_EQ(Options::fromSettings(stored).feature_retry, 1.0);
  // ... and one stored before a frame's candidates were counted as one family of tests and a
  // place had to share the frame's scene (issue 45): it resumes deciding as it did.
  stored = Options().toSettings();
  stored.erase("geometry_count_candidates");
  stored.erase("geometry_min_scene_share");
  EXPECT_FALSE(Options::fromStoredSettings(stored).geometry_count_candidates);
  EXPECT_EQ(Options::fromStoredSettings(stored).geometry_min_scene_share, 0.0);
  EXPECT_TRUE(Options::fromSettings(stored).geometry_count_candidates);
  EXPECT_EQ(Options::fromSettings(stored).geometry_min_scene_share, 0.25);
  // ... and one stored before a closure had to be what the frame's way here singles out.
  stored = Options().toSettings();
  stored.erase("geometry_way_here_checks");
  EXPECT_EQ(Options::fromStoredSettings(stored).geometry_way_here_checks, 0);
  EXPECT_EQ(Options::fromSettings(stored).geometry_way_here_checks, 8);
  // ... and one stored while its places were all counted alike, a closure run outlived a frame
  // that showed its place to be an object, and a location was seen from its first frame only.
  stored = Options().toSettings();
  stored["geometry_way_here_checks"] = "4";
  stored.erase("geometry_way_here_ranked");
  stored.erase("temporal_end_on_object");
  stored.erase("geometry_latest_view");
  EXPECT_EQ(Options::fromStoredSettings(stored).geometry_way_here_checks, 4);
  EXPECT_FALSE(Options::fromStoredSettings(stored).geometry_latest_view);
  EXPECT_TRUE(Options::fromSettings(stored).geometry_latest_view);
  EXPECT_FALSE(Options::fromStoredSettings(stored).geometry_way_here_ranked);
  EXPECT_FALSE(Options::fromStoredSettings(stored).temporal_end_on_object);
  EXPECT_TRUE(Options::fromSettings(stored).geometry_way_here_ranked);
  EXPECT_TRUE(Options::fromSettings(stored).temporal_end_on_object);
}

}  // namespace
}  // namespace placedb
