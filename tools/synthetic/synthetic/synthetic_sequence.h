#pragma once
// A synthetic image sequence with exact loop-closure ground truth: a camera driving through an
// endless procedurally textured town (a tilted camera over a textured ground plane), exploring
// new streets and driving some again. Used by `placedb demo`, the scale benchmark and tests.
// The canyon scenes (canyon.h) put a forward-looking camera in a corridor or a street instead,
// on a walk that never comes back.
//
// Everything is a deterministic function of the options: the same seed gives byte-identical
// images and ground truth. Poses and ground truth are computed up front (a few dozen bytes per
// frame); images are rendered on demand from a tile cache, so sequences of any length fit in
// memory.
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "synthetic/camera_model.h"
#include "synthetic/lookalikes.h"

namespace placedb::synthetic {

class CanyonWorld;
class GroundTexture;

struct SyntheticOptions {
  std::uint64_t seed = 1;
  // The world: "ground", the endless textured plane seen from above by a tilted camera; or
  // "corridor" or "street" (canyon.h), a straight box along a single_pass walk seen by a
  // camera that looks ahead. sceneDefaults() gives each scene's camera.
  std::string scene = "ground";
  int frames = 300;
  int width = 320, height = 240;
  // "demo": explore the first third, then repeat streets for ~40% of the frames, interleaved
  // with more exploration. "scale": a long exploration of a growing town with periodic repeats
  // of earlier (often long-forgotten) streets, ~25% of the frames. "single_pass": one straight
  // street that is never driven again (no revisit: every loop closure on it is false).
  std::string profile = "demo";

  // Objects that stand at more than one place (lookalikes.h): "none", "poster" (one poster at
  // two places lookalike_gap frames apart) or "corridor" (a door and lockers on both sides
  // every lookalike_pitch metres). ground_contrast scales the ground texture's contrast about
  // mid-grey (in a canyon, the floor's): below 1, a blander floor, where the objects give most
  // of the features.
  std::string lookalike = "none";
  int lookalike_gap = 48;
  double lookalike_pitch = 3.0;
  double ground_contrast = 1.0;

  // Route. Negative or zero values take the profile's default.
  double revisit_fraction = -1;        // share of the route planned as repeated streets
  double first_revisit_fraction = -1;  // share of the route explored before the first repeat
  double block_length = 0;             // metres between intersections
  int min_revisit_gap = 50;            // frames; closer pairs never count as loops
  double speed = 0.6;                  // metres per frame

  // Camera: height above the ground, tilt below the horizon, horizontal field of view.
  double camera_height = 6.0;
  double pitch_degrees = 60.0;
  double hfov_degrees = 60.0;

  // What differs between two visits of a place (all smooth in time and seeded).
  double lateral_wander = 0.8;  // metres across the street
  double heading_wander_degrees = 3.0;
  double pitch_wander_degrees = 2.0;
  double height_wander = 0.3;       // metres
  double exposure_change = 0.2;     // relative gain swing
  double brightness_change = 14.0;  // grey levels of offset swing
  double shading_change = 14.0;     // grey levels of a linear light gradient across the image
  double noise_sigma = 2.0;         // grey levels of per-pixel sensor noise

  // The canyon scenes' box: walls canyon_half_width either side of its centre line, the walk
  // canyon_walk_offset to the left of that line (negative: nearer the right-hand wall), the
  // ceiling or the facades' top canyon_height above the floor. Metres; a corridor's here.
  double canyon_half_width = 1.2;
  double canyon_height = 2.6;
  double canyon_walk_offset = 0;

  // Ground truth (see ground_truth.h): frames at least min_revisit_gap apart whose views share
  // at least this much of the smaller ground footprint.
  double gt_min_shared = 0.25;

  std::size_t tile_cache = 256;  // texture tiles kept (64 KiB each)
};

// The options of a scene with its own camera: for "ground", SyntheticOptions' defaults; for
// "corridor" and "street", a walker's forward-looking camera (1.5 m up, pitched 6 degrees down,
// a small sway) on a single_pass walk, in a corridor 2.4 m wide and 2.6 m high, or on the
// pavement of a street 12 m wide between facades 10 m high; look-alikes repeat every 6 m. Throws
// placedb::Error (kInvalidArgument) for an unknown scene.
SyntheticOptions sceneDefaults(const std::string& scene);

class SyntheticSequence {
 public:
  // Throws placedb::Error(kInvalidArgument) on impossible options.
  explicit SyntheticSequence(const SyntheticOptions& options);
  ~SyntheticSequence();
  SyntheticSequence(const SyntheticSequence&) = delete;
  SyntheticSequence& operator=(const SyntheticSequence&) = delete;

  int size() const { return static_cast<int>(poses_.size()); }
  const SyntheticOptions& options() const { return options_; }
  const CameraIntrinsics& camera() const { return camera_; }
  // The corridor or street of a canyon scene; null in the ground scene.
  const CanyonWorld* canyon() const { return canyon_.get(); }

  // Frame i as 8-bit grey, width x height. Thread-safe (the tile cache is locked).
  cv::Mat render(int i) const;
  // The same image before exposure, shading and noise: pure geometry, for checks.
  cv::Mat renderClean(int i) const;

  Pose pose(int i) const;
  // The ground seen by frame i, and the map from the pixels of frame `from` to those of frame
  // `to` (exact: that world is a plane). Ground scene only: a canyon's forward-looking camera
  // sees an unbounded stretch of floor and more than one plane (kInvalidArgument).
  std::array<cv::Point2d, 4> footprint(int i) const;
  cv::Matx33d homography(int from, int to) const;

  // (q, r) with q > r: frame q revisits the place of frame r. Sorted by q then r.
  const std::vector<std::pair<int, int>>& groundTruth() const { return pairs_; }
  // Every r that frame q revisits, ascending.
  std::vector<int> revisitsOf(int q) const;
  // Of each earlier pass over q's place (a run of revisited frames, each within 2 of the last),
  // the frame whose view overlaps q's most (footprint IoU): the right frame for a closure to
  // name. Ascending.
  std::vector<int> nearestViewsOf(int q) const;
  int revisitingFrames() const;  // frames with at least one r
  int firstRevisit() const;      // smallest such q, or -1

 private:
  const Pose& checkedPose(int i) const;
  void requireGround(const char* what) const;

  SyntheticOptions options_;
  CameraIntrinsics camera_;
  std::vector<Pose> poses_;
  std::vector<std::pair<int, int>> pairs_;
  std::vector<std::size_t> first_pair_;  // pairs_ of frame q are [first_pair_[q], first_pair_[q+1])
  std::unique_ptr<GroundTexture> texture_;
  std::vector<Decal> decals_;
  std::unique_ptr<CanyonWorld> canyon_;
  cv::Mat ramp_x_, ramp_y_;  // -0.5..0.5 across the image, for light gradients
};

// Called after each image written: (images done, images in all).
using SequenceProgress = std::function<void(int done, int total)>;

// Writes dir/images/000000.png ..., dir/frames.txt (image paths relative to dir, one a line) and
// dir/gt_pairs.txt (a '#' header line, then "q r" lines), the layout of the shared data sets.
// Creates dir if needed. Throws placedb::Error(kIo) when something cannot be written.
void writeSequence(const SyntheticSequence& sequence, const std::filesystem::path& dir,
                   const SequenceProgress& progress = {});

}  // namespace placedb::synthetic
