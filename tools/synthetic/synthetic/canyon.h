#pragma once
// The canyon scenes: a straight box along a walk that never comes back, seen from inside by a
// forward-looking camera that sees the horizon, as a hand-held phone or a robot's camera does.
//   "corridor": a floor, two walls, a ceiling and an end wall, as bland as corridors are.
//   "street":   a textured ground, building facades, a far facade across the end and an open,
//               featureless sky above the facades.
// Each surface is a plane with its own 2D coordinates in metres and its own procedural texture
// (GroundTexture, seeded per surface); look-alikes (lookalikes.h) stand upright on the side walls.
//
// Seen from inside a convex box, every pixel's ray leaves it through exactly one surface: the
// one whose plane it meets nearest in front of the camera. Each pixel is mapped from the image
// to that surface's coordinates through its own ray (an inverse map, valid for every pixel,
// unlike projecting surfaces into the image, which fails for points behind the camera), and the
// texture is read with a footprint filter (ripmap.h), since the walls far ahead are seen at a
// grazing angle.
#include <cstdint>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "synthetic/camera_model.h"
#include "synthetic/lookalikes.h"

namespace placedb::synthetic {

struct SyntheticOptions;

// The box, in the ground scene's coordinates: the walk runs along +x from x = 0 at y = 0.
struct CanyonBox {
  double x_start = 0, x_end = 0;   // the walls behind the walk's start and beyond its end
  double y_left = 0, y_right = 0;  // the side walls, y_left > 0 > y_right
  double height = 0;               // of the ceiling, or of the facades
  bool sky = false;                // above the facades is sky, not a ceiling
};

// The box of options.scene ("corridor" or "street") around its walk of options.frames.
CanyonBox canyonBox(const SyntheticOptions& options);

// Throws placedb::Error(kInvalidArgument) unless the options describe a camera inside the box
// that looks ahead (the horizon in view) on a single pass.
void validateCanyon(const SyntheticOptions& options, const CameraIntrinsics& camera);

enum class CanyonSurface : std::uint8_t { kFloor, kLeft, kRight, kTop, kEnd, kStart };
constexpr int kCanyonSurfaces = 6;

class CanyonWorld {
 public:
  // Paints every surface's texture (a few hundred milliseconds for a street of 100 m).
  CanyonWorld(const SyntheticOptions& options, std::vector<WallDecal> decals);
  ~CanyonWorld();
  CanyonWorld(const CanyonWorld&) = delete;
  CanyonWorld& operator=(const CanyonWorld&) = delete;

  const CanyonBox& box() const { return box_; }
  const std::vector<WallDecal>& decals() const { return decals_; }

  // The image of the camera at `pose`, 8-bit grey, before exposure, shading and noise.
  // Thread-safe: everything it reads is made by the constructor.
  cv::Mat render(const Pose& pose, const CameraIntrinsics& camera) const;
  // The surface each pixel sees (CanyonSurface values, 8-bit), for checks.
  cv::Mat surfaces(const Pose& pose, const CameraIntrinsics& camera) const;

 private:
  struct Surface;
  struct Picture;
  struct View;
  // The two surfaces a pixel's ray meets first, and their nearness (1 / depth).
  struct Exit {
    int best = 0, second = 0;
    double best_near = 0, second_near = 0;
  };

  View view(const Pose& pose, const CameraIntrinsics& camera) const;
  float shade(const View& view, int k, double u, double v) const;

  CanyonBox box_;
  std::vector<WallDecal> decals_;
  std::vector<Surface> surfaces_;  // indexed by CanyonSurface
  std::vector<Picture> pictures_;  // one per distinct decal picture
};

}  // namespace placedb::synthetic
