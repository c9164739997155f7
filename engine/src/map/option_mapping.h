#pragma once
// From the public Options to each component's own settings struct.
#include "decision/closure_run.h"
#include "features/feature_options.h"
#include "filter/filter_settings.h"
#include "geometry/geometry.h"
#include "memory/memory_tiers.h"
#include "placedb/options.h"
#include "vocabulary/vocabulary.h"

namespace placedb {

FeatureOptions toFeatureOptions(const Options& options);
vocab::VocabularyOptions toVocabularyOptions(const Options& options);
BayesFilterSettings toFilterSettings(const Options& options);
MemorySettings toMemorySettings(const Options& options);
GeometricCheckSettings toGeometricCheckSettings(const Options& options);
RunSettings toRunSettings(const Options& options);
bool geometricCheckOn(const Options& options);  // geometry_min_inliers or _max_nfa not 0

}  // namespace placedb
