#pragma once
// The small mapping scenario shared by the reliability tests and their child mapper: a synthetic
// sequence with loops and a working memory small enough that transfers and retrievals happen, so
// a resume has to restore every tier.
#include <string>

#include "placedb/options.h"
#include "synthetic/synthetic_sequence.h"

namespace placedb::testing {

inline synthetic::SyntheticOptions crashSequenceOptions(int frames) {
  synthetic::SyntheticOptions o;
  o.profile = "demo";
  o.frames = frames;
  o.seed = 7;
  o.width = 200;
  o.height = 150;
  o.min_revisit_gap = 20;
  o.speed = 2.0;
  return o;
}

inline Options crashMapOptions() {
  Options o;
  o.wm_max = 15;
  o.max_features = 200;
  o.geometry_min_inliers = 8;  // small frames: fewer matches than the default needs
  return o;
}

}  // namespace placedb::testing
