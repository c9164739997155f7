#pragma once
// Look-alikes: the same object at more than one place. A place-recognition engine that takes one
// object for a place closes a loop between two places that only share it: the same poster or
// newspaper stand at two street corners, doors and lockers that repeat along a corridor. These
// worlds hold such objects on a walk that never comes back, so every loop closure accepted on
// them is false.
//
// An object is a flat picture lying on the ground (the synthetic world is a plane), painted over
// the ground texture: one poster at two places `lookalike_gap` frames apart along the route, or a
// door-and-lockers motif on both sides of the route every `lookalike_pitch` metres. Every copy of
// an object is the same picture, pixel for pixel.
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "synthetic/camera_model.h"

namespace placedb::synthetic {

struct SyntheticOptions;

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

}  // namespace placedb::synthetic
