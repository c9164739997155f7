// placedb_walk_sequence: a synthetic walk with frame-exact ground truth, to measure whether
// accepted loop closures land on the right frame or trail the camera by a few.
//
// The shared data sets' ground truth is offset along whole stretches (lip6_outdoor's third pass
// lies about nine frames from the place that agrees best), so a closure's frame offset cannot be
// read from them. The synthetic town's poses are exact: for every revisiting frame q and every
// earlier pass over its place, the frame r of that pass whose ground footprint overlaps q's the
// most (IoU) is the right frame. Writes, besides the sequence (images, frames.txt, gt_pairs.txt
// of synthetic_sequence.h's rule):
//   gt_nearest.txt  "q r" for those right frames only: scored at window 2 it asks what the
//                   ground truth of a hand-held walk asks, a closure within two frames;
//   poses.txt       "frame x y heading" (metres, radians), for offsets.py.
//
// A low camera looking ahead (--camera-height 1.5 --pitch 30) sees the ground to 12 m, as a
// hand-held camera sees a corridor or a pavement; bench/quality/offsets.py reads the two files.
//
// Usage: placedb_walk_sequence OUT [--scene ground|corridor|street] [--frames N] [--width W]
//                              [--height H] [--speed M] [--seed S] [--hfov DEG] [--pitch DEG]
//                              [--camera-height M] [--profile demo|single_pass]
//                              [--lookalike none|poster|corridor] [--lookalike-gap FRAMES]
//                              [--lookalike-pitch M] [--ground-contrast C]
//                              [--canyon-half-width M] [--canyon-height M] [--canyon-offset M]
//
// With --profile single_pass the walk never comes back (gt_pairs.txt is empty) and a lookalike
// (synthetic/lookalikes.h) puts one object at two places or a motif along a corridor: the
// negative checks of bench/quality/precision.py, where every accepted closure is false.
//
// --scene corridor or street (synthetic/canyon.h) walks a single pass down a corridor or a
// street with a forward-looking camera, the scene's own (sceneDefaults(): 1.5 m up, pitched
// 6 degrees down, 60 degrees wide) unless the flags say otherwise; the lookalikes stand upright
// on its walls. gt_pairs.txt and gt_nearest.txt are empty there, poses.txt is written as ever.
//
// Issue 45's negative walks (placedb_walk_sequence OUT and these flags): a corridor of doors and
// lockers and a street with one poster at two places, at 960x540 as a phone sees them and at
// 160x120 as a small wide-angle robot camera does.
//   --frames 200 --scene corridor --lookalike corridor
//   --frames 200 --scene corridor --lookalike corridor --width 160 --height 120 --hfov 95
//   --frames 200 --scene street --lookalike poster
//   --frames 200 --scene street --lookalike poster --width 160 --height 120 --hfov 95
#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "placedb/error.h"
#include "synthetic/ground_truth.h"
#include "synthetic/synthetic_sequence.h"

namespace {

using placedb::synthetic::SyntheticOptions;
using placedb::synthetic::SyntheticSequence;

int usage(std::FILE* to, int code) {
  std::fputs(
      "usage: placedb_walk_sequence OUT [--scene ground|corridor|street] [--frames N]\n"
      "                             [--width W] [--height H] [--speed M] [--seed S]\n"
      "                             [--hfov DEG] [--pitch DEG] [--camera-height M]\n"
      "                             [--profile demo|single_pass]\n"
      "                             [--lookalike none|poster|corridor]\n"
      "                             [--lookalike-gap FRAMES] [--lookalike-pitch M]\n"
      "                             [--ground-contrast C] [--canyon-half-width M]\n"
      "                             [--canyon-height M] [--canyon-offset M]\n"
      "corridor and street scenes walk a single pass with a forward-looking camera\n",
      to);
  return code;
}

}  // namespace

int main(int argc, char** argv) {
  // OUT is a folder the walk is written into: "--help" there would make one of that name.
  if (argc >= 2 && (std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h"))
    return usage(stdout, 0);
  if (argc < 2 || argc % 2 != 0 || argv[1][0] == '-') return usage(stderr, 2);
  // The scene first: its camera is the starting point the other flags change.
  std::string scene = "ground";
  for (int i = 2; i + 1 < argc; i += 2) {
    if (std::string(argv[i]) == "--scene") scene = argv[i + 1];
  }
  SyntheticOptions options;
  try {
    options = placedb::synthetic::sceneDefaults(scene);
  } catch (const placedb::Error& e) {
    std::fprintf(stderr, "placedb_walk_sequence: %s\n", e.what());
    return 1;
  }
  options.frames = 600;
  options.width = 960;
  options.height = 540;
  options.speed = 0.3;  // a walk: half the demo's drive per frame
  std::string out = argv[1];
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string key = argv[i];
    const char* value = argv[i + 1];
    if (key == "--scene") {
      continue;
    } else if (key == "--frames") {
      options.frames = std::atoi(value);
    } else if (key == "--width") {
      options.width = std::atoi(value);
    } else if (key == "--height") {
      options.height = std::atoi(value);
    } else if (key == "--speed") {
      options.speed = std::atof(value);
    } else if (key == "--seed") {
      options.seed = std::strtoull(value, nullptr, 10);
    } else if (key == "--hfov") {
      options.hfov_degrees = std::atof(value);
    } else if (key == "--pitch") {
      options.pitch_degrees = std::atof(value);
    } else if (key == "--camera-height") {
      options.camera_height = std::atof(value);
    } else if (key == "--profile") {
      options.profile = value;
    } else if (key == "--lookalike") {
      options.lookalike = value;
    } else if (key == "--lookalike-gap") {
      options.lookalike_gap = std::atoi(value);
    } else if (key == "--lookalike-pitch") {
      options.lookalike_pitch = std::atof(value);
    } else if (key == "--ground-contrast") {
      options.ground_contrast = std::atof(value);
    } else if (key == "--canyon-half-width") {
      options.canyon_half_width = std::atof(value);
    } else if (key == "--canyon-height") {
      options.canyon_height = std::atof(value);
    } else if (key == "--canyon-offset") {
      options.canyon_walk_offset = std::atof(value);
    } else {
      return usage(stderr, 2);
    }
  }
  try {
    SyntheticSequence sequence(options);
    placedb::synthetic::writeSequence(sequence, out);
    std::ofstream nearest(out + "/gt_nearest.txt"), poses(out + "/poses.txt");
    nearest << "# q r : the frame of each earlier pass over q's place whose view overlaps q's "
               "most\n";
    for (int q = 0; q < sequence.size(); ++q) {
      const auto p = sequence.pose(q);
      poses << fmt::format("{} {:.4f} {:.4f} {:.5f}\n", q, p.x, p.y, p.heading);
      for (int r : sequence.nearestViewsOf(q)) nearest << q << ' ' << r << '\n';
    }
    if (!nearest || !poses) throw placedb::Error(placedb::ErrorCode::kIo, "cannot write " + out);
    std::printf("%d frames, %d revisiting, in %s\n", sequence.size(), sequence.revisitingFrames(),
                out.c_str());
  } catch (const placedb::Error& e) {
    std::fprintf(stderr, "placedb_walk_sequence: %s\n", e.what());
    return 1;
  }
  return 0;
}
