#pragma once
// What the decision tests read of each frame of a run, and the runs themselves: a sequence mapped
// into a fresh map, closed and reopened after chosen frames, and a synthetic walk rendered as a
// sequence.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "engine_fixture.h"
#include "synthetic/synthetic_sequence.h"

namespace placedb::testing {

struct Frame {
  bool accepted = false;
  int inliers = 0;
  double log10_nfa = 0;
  int evidence_frames = 0;  // > 1: passed as a run of frames (closure_evidence.h)
  std::int64_t hypothesis = 0;
  std::vector<std::int64_t> source_indices;  // frames the hypothesis covers
  std::string rejected;                      // why the hypothesis was refused, empty if it was not
};

// Maps every frame of `seq` into a fresh map; the map is closed after each frame in stop_after
// and resumed.
inline std::vector<Frame> mapFrames(const Sequence& seq, const std::string& source,
                                    const std::string& name, const Options& options,
                                    const std::set<std::size_t>& stop_after) {
  auto path = scratchDir(name) / "map.placedb";
  removeMap(path);
  std::vector<Frame> out;
  std::unique_ptr<Map> map;
  for (std::size_t i = 0; i < seq.images.size(); ++i) {
    if (!map) map = openForFrame(path, options, i, source);
    const FrameResult r = map->process(seq.images[i], static_cast<std::int64_t>(i), seq.paths[i]);
    Frame f;
    f.accepted = r.hypothesis.accepted;
    f.inliers = r.hypothesis.inliers;
    f.log10_nfa = r.hypothesis.log10_nfa;
    f.evidence_frames = r.hypothesis.evidence_frames;
    f.hypothesis = r.hypothesis.location_id;
    for (const auto& ref : r.hypothesis.frames) f.source_indices.push_back(ref.source_index);
    f.rejected = r.hypothesis.rejected_reason;
    out.push_back(f);
    if (stop_after.count(i)) map.reset();  // destructor closes
  }
  return out;
}

// Every frame of a synthetic walk, named as files under `folder` would be.
inline Sequence rendered(const synthetic::SyntheticSequence& walk, const std::string& folder) {
  Sequence seq;
  for (int i = 0; i < walk.size(); ++i) {
    seq.images.push_back(walk.render(i));
    seq.paths.push_back(folder + "/" + std::to_string(i) + ".png");
  }
  return seq;
}

// A walk on the ground world that drives part of its route again (960x540, 0.5 m a frame, the
// camera 1.5 m up and pitched 30 degrees down) with exact ground truth: frames 0-599, its second
// pass from about frame 250.
inline synthetic::SyntheticOptions revisitingWalk() {
  synthetic::SyntheticOptions o;
  o.frames = 600;
  o.width = 960;
  o.height = 540;
  o.speed = 0.5;
  o.pitch_degrees = 30;
  o.camera_height = 1.5;
  return o;
}

}  // namespace placedb::testing
