#pragma once
// Look-alikes: the same object at more than one place. A place-recognition engine that takes one
// object for a place closes a loop between two places that only share it: the same poster or
// newspaper stand at two street corners, doors and lockers that repeat along a corridor. These
// worlds hold such objects on a walk that never comes back, so every loop closure accepted on
// them is false.
//
// In the ground scene an object is a flat picture lying on the ground (that world is a plane),
// painted over the ground texture: one poster at two places `lookalike_gap` frames apart along
// the route, or a door-and-lockers motif on both sides of the route every `lookalike_pitch`
// metres. In the canyon scenes (canyon.h) the same objects stand upright on the walls, at their
// real sizes. Every copy of an object is the same picture, pixel for pixel.
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "synthetic/camera_model.h"

namespace placedb::synthetic {

struct SyntheticOptions;
struct CanyonBox;

struct Decal {
  std::shared_ptr<const cv::Mat> picture;  // 8-bit grey, pixels_per_metre
  double pixels_per_metre = 160;
  cv::Point2d centre;  // ground metres
  double angle = 0;    // radians, counter-clockwise: the picture's +x axis on the ground
};

// The objects of `options.lookalike` ("none", "poster", "corridor") along the route of `poses`.
// Throws placedb::Error(kInvalidArgument) for an unknown kind.
std::vector<Decal> placeLookalikes(const SyntheticOptions& options, const std::vector<Pose>& poses);

// Paints the decals that the camera at `pose` sees over `frame` (its ground, width x height).
void paintDecals(cv::Mat& frame, const std::vector<Decal>& decals, const Pose& pose,
                 const CameraIntrinsics& camera);

// A picture that stands upright on a wall: what it shows and what of the wall it covers (a door
// and lockers leave the wall between them visible). Row 0 is the picture's top.
struct UprightPicture {
  cv::Mat grey;  // 8-bit
  cv::Mat mask;  // 8-bit, 255 where the picture covers the wall, 0 where the wall shows
  double pixels_per_metre = 160;
  double width() const { return grey.cols / pixels_per_metre; }
  double height() const { return grey.rows / pixels_per_metre; }
};

enum class WallSide { kLeft, kRight };  // as seen walking along +x

struct WallDecal {
  std::shared_ptr<const UprightPicture> picture;
  WallSide side = WallSide::kLeft;
  double x = 0;       // metres: where along the canyon the picture's centre is
  double bottom = 0;  // metres above the floor of the picture's lower edge
};

// The objects of `options.lookalike` on the walls of `box` along the straight walk of `poses`:
// "poster", one poster on the right-hand wall ahead of two frames lookalike_gap apart; "corridor",
// a door and lockers on both walls every lookalike_pitch metres from end to end.
// Throws placedb::Error(kInvalidArgument) for an unknown kind.
std::vector<WallDecal> placeWallLookalikes(const SyntheticOptions& options,
                                           const std::vector<Pose>& poses, const CanyonBox& box);

}  // namespace placedb::synthetic
