#include "synthetic/canyon.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <string>

#include <opencv2/core/utility.hpp>

#include "placedb/error.h"
#include "synthetic/ground_texture.h"
#include "synthetic/ripmap.h"
#include "synthetic/seeded_random.h"
#include "synthetic/synthetic_sequence.h"

namespace placedb::synthetic {
namespace {

constexpr double kDegree = CV_PI / 180.0;
constexpr double kTexelsPerMetre = GroundTexture::kTexelsPerMetre;
constexpr std::uint64_t kSurfaceSalt = 0xca4e05;
// The camera keeps at least this far from every surface: a walker's, not a wall's, view.
constexpr double kClearance = 0.3;
// Texels of transparent border round every decal picture, so that its edge filters smoothly.
constexpr int kDecalBorder = 2;

void require(bool ok, const std::string& what) {
  if (!ok) throw Error(ErrorCode::kInvalidArgument, "synthetic sequence: " + what);
}

// How a surface looks: its texture with the grey levels mean + contrast * (texel - 128), or a
// flat grey (mean) with nothing in it.
struct Look {
  double mean = 128, contrast = 1;
  bool flat = false;
};

// Corridors: painted walls and ceilings are bland, the floor (tiles, lino) a little less, and the
// end wall far ahead is one more wall. Streets: facades and the ground at full contrast, and an
// overcast sky with nothing in it to match. The start wall behind the walk is never in view.
std::array<Look, kCanyonSurfaces> looksOf(const SyntheticOptions& o) {
  const bool street = o.scene == "street";
  const Look floor{street ? 128.0 : 112.0, (street ? 1.0 : 0.6) * o.ground_contrast};
  const Look side = street ? Look{128, 1.0} : Look{165, 0.4};
  const Look top = street ? Look{205, 0, true} : Look{198, 0.3};
  return {floor, side, side, top, side, Look{side.mean, 0, true}};
}

}  // namespace

struct CanyonWorld::Surface {
  PlaneFrame plane;
  cv::Vec3d inward;  // the plane's normal, s_axis x t_axis, pointing into the box
  Look look;
  std::unique_ptr<RipMap> texture;  // null for a flat surface
  cv::Point2d texel_origin;         // texture (0, 0) in texels of (s, -t): t grows upwards
  struct Placed {
    double s0 = 0, s1 = 0, t_top = 0;  // metres: the picture's left and right edges, its top
    int picture = 0;
  };
  std::vector<Placed> placed;  // decals on this surface, by s0
  double widest = 0;           // metres: the widest decal
};

struct CanyonWorld::Picture {
  Picture(const UprightPicture& source, const cv::Mat& premultiplied, const cv::Mat& mask)
      : pixels_per_metre(source.pixels_per_metre), grey(premultiplied), coverage(mask) {}
  double pixels_per_metre;
  RipMap grey;      // premultiplied by the coverage, so that filtering blends edges right
  RipMap coverage;  // 255 where the picture covers the wall
};

// One camera's view: for every surface, its nearness (1 / depth, linear in the pixel: a u +
// b v + c) and the homography from pixels to its (s, t).
struct CanyonWorld::View {
  std::array<cv::Vec3d, kCanyonSurfaces> nearness;
  std::array<cv::Matx33d, kCanyonSurfaces> to_surface;
  Exit exit(double u, double v) const;
};

CanyonBox canyonBox(const SyntheticOptions& o) {
  CanyonBox box;
  const bool street = o.scene == "street";
  box.x_start = -10;
  // Far beyond the last frame, as a long corridor's end or a street's far crossing is.
  box.x_end = (o.frames - 1) * o.speed + (street ? 50.0 : 20.0);
  box.y_left = o.canyon_half_width - o.canyon_walk_offset;
  box.y_right = -o.canyon_half_width - o.canyon_walk_offset;
  box.height = o.canyon_height;
  box.sky = street;
  return box;
}

void validateCanyon(const SyntheticOptions& o, const CameraIntrinsics& camera) {
  require(o.profile == "single_pass", "scene \"" + o.scene + "\" walks only the profile " +
                                          "\"single_pass\" (a straight box has no streets to " +
                                          "come back along), not \"" + o.profile + "\"");
  require(o.canyon_half_width >= 0.5 && o.canyon_half_width <= 50,
          "canyon_half_width must be in [0.5, 50] metres");
  require(o.canyon_height >= 1 && o.canyon_height <= 200,
          "canyon_height must be in [1, 200] metres");
  require(std::abs(o.canyon_walk_offset) + o.lateral_wander <= o.canyon_half_width - kClearance,
          "the walk (canyon_walk_offset, give or take lateral_wander) must keep 0.3 m from the "
          "side walls");
  require(o.camera_height - o.height_wander >= kClearance &&
              o.camera_height + o.height_wander <= o.canyon_height - kClearance,
          std::string("camera_height (give or take height_wander) must keep 0.3 m above the floor "
                      "and below the ") +
              (o.scene == "street" ? "facades' top" : "ceiling"));
  // A camera that looks ahead sees the horizon, the far end of the box; one pitched beyond
  // half its vertical field of view sees only the floor or only the ceiling.
  const double half_vfov = camera.verticalFov() / kDegree / 2;
  require(
      std::abs(o.pitch_degrees) + o.pitch_wander_degrees < half_vfov,
      "pitch_degrees (give or take pitch_wander_degrees) must keep the horizon in view, within " +
          std::to_string(static_cast<int>(half_vfov)) + " degrees of the optical axis");
  require(o.frames * o.speed <= 5000,
          "the walk must be at most 5 km long (textures are kept whole)");
  require(o.lookalike_pitch >= 1, "lookalike_pitch must be at least 1 metre in a canyon");
}

CanyonWorld::CanyonWorld(const SyntheticOptions& o, std::vector<WallDecal> decals)
    : box_(canyonBox(o)), decals_(std::move(decals)) {
  const CanyonBox& b = box_;
  const cv::Vec3d x(1, 0, 0), y(0, 1, 0), z(0, 0, 1);
  // Each surface's (s, t) reads the right way round from inside: s to the right, t up on walls.
  struct Extent {
    PlaneFrame plane;
    double s0, s1, t0, t1;
  };
  const std::array<Extent, kCanyonSurfaces> extents = {{
      {{{0, 0, 0}, x, y}, b.x_start, b.x_end, b.y_right, b.y_left},
      {{{0, b.y_left, 0}, x, z}, b.x_start, b.x_end, 0, b.height},
      {{{0, b.y_right, 0}, -x, z}, -b.x_end, -b.x_start, 0, b.height},
      {{{0, 0, b.height}, x, -y}, b.x_start, b.x_end, -b.y_left, -b.y_right},
      {{{b.x_end, 0, 0}, -y, z}, -b.y_left, -b.y_right, 0, b.height},
      {{{b.x_start, 0, 0}, y, z}, b.y_right, b.y_left, 0, b.height},
  }};
  const std::array<Look, kCanyonSurfaces> looks = looksOf(o);
  surfaces_.resize(kCanyonSurfaces);
  // Surfaces are painted side by side; each is a pure function of the seed and its index.
  cv::parallel_for_(cv::Range(0, kCanyonSurfaces), [&](const cv::Range& range) {
    for (int k = range.start; k < range.end; ++k) {
      Surface& s = surfaces_[static_cast<std::size_t>(k)];
      const Extent& e = extents[static_cast<std::size_t>(k)];
      s.plane = e.plane;
      s.inward = e.plane.s_axis.cross(e.plane.t_axis);
      s.look = looks[static_cast<std::size_t>(k)];
      if (s.look.flat) continue;
      const int col0 = static_cast<int>(std::floor(e.s0 * kTexelsPerMetre)) - 2;
      const int row0 = static_cast<int>(std::floor(-e.t1 * kTexelsPerMetre)) - 2;
      const cv::Rect texels(col0, row0,
                            static_cast<int>(std::ceil(e.s1 * kTexelsPerMetre)) + 3 - col0,
                            static_cast<int>(std::ceil(-e.t0 * kTexelsPerMetre)) + 3 - row0);
      const GroundTexture texture(hashOf(o.seed, kSurfaceSalt, k), 4);
      cv::Mat base = texture.mosaic(texels);
      base.convertTo(base, CV_8U, s.look.contrast, s.look.mean - 128 * s.look.contrast);
      s.texture = std::make_unique<RipMap>(base);
      s.texel_origin = cv::Point2d(col0, row0);
    }
  });

  std::map<const UprightPicture*, int> picture_index;
  for (const WallDecal& d : decals_) {
    const UprightPicture& source = *d.picture;
    auto [found, added] = picture_index.emplace(&source, static_cast<int>(pictures_.size()));
    if (added) {
      cv::Mat grey, mask;
      cv::copyMakeBorder(source.grey, grey, kDecalBorder, kDecalBorder, kDecalBorder, kDecalBorder,
                         cv::BORDER_CONSTANT, cv::Scalar(0));
      cv::copyMakeBorder(source.mask, mask, kDecalBorder, kDecalBorder, kDecalBorder, kDecalBorder,
                         cv::BORDER_CONSTANT, cv::Scalar(0));
      cv::Mat premultiplied;
      cv::multiply(grey, mask, premultiplied, 1.0 / 255);
      pictures_.emplace_back(source, premultiplied, mask);
    }
    const double border = kDecalBorder / source.pixels_per_metre;
    const double half = 0.5 * source.width() + border;
    const bool left = d.side == WallSide::kLeft;
    Surface& wall =
        surfaces_[static_cast<std::size_t>(left ? CanyonSurface::kLeft : CanyonSurface::kRight)];
    const double s_centre = left ? d.x : -d.x;  // the right wall's s runs along -x
    wall.placed.push_back(
        {s_centre - half, s_centre + half, d.bottom + source.height() + border, found->second});
    wall.widest = std::max(wall.widest, 2 * half);
  }
  for (Surface& s : surfaces_) {
    std::stable_sort(
        s.placed.begin(), s.placed.end(),
        [](const Surface::Placed& a, const Surface::Placed& b) { return a.s0 < b.s0; });
  }
}

CanyonWorld::~CanyonWorld() = default;

CanyonWorld::View CanyonWorld::view(const Pose& pose, const CameraIntrinsics& camera) const {
  View v;
  const cv::Matx33d rays = pixelRays(pose, camera);
  const cv::Vec3d centre(pose.x, pose.y, pose.height);
  for (int k = 0; k < kCanyonSurfaces; ++k) {
    const Surface& s = surfaces_[static_cast<std::size_t>(k)];
    // The ray of pixel p, rays * p, meets the plane at depth D / -(n . rays * p), with D the
    // camera's height above the plane (positive inside the box), when that is positive.
    const double above = s.inward.dot(centre - s.plane.origin);
    const cv::Matx13d row = cv::Matx13d(s.inward[0], s.inward[1], s.inward[2]) * rays;
    v.nearness[static_cast<std::size_t>(k)] =
        cv::Vec3d(-row(0, 0) / above, -row(0, 1) / above, -row(0, 2) / above);
    v.to_surface[static_cast<std::size_t>(k)] = imageToPlane(pose, camera, s.plane);
  }
  return v;
}

float CanyonWorld::shade(const View& view, int k, double u, double v) const {
  const Surface& surface = surfaces_[static_cast<std::size_t>(k)];
  if (!surface.texture) return static_cast<float>(surface.look.mean);
  const cv::Matx33d& h = view.to_surface[static_cast<std::size_t>(k)];
  const double inv = 1.0 / (h(2, 0) * u + h(2, 1) * v + h(2, 2));
  const double s = (h(0, 0) * u + h(0, 1) * v + h(0, 2)) * inv;
  const double t = (h(1, 0) * u + h(1, 1) * v + h(1, 2)) * inv;
  // Metres of s and t that one pixel spans (the homography's derivatives).
  const double s_span =
      std::max(std::abs((h(0, 0) - s * h(2, 0)) * inv), std::abs((h(0, 1) - s * h(2, 1)) * inv));
  const double t_span =
      std::max(std::abs((h(1, 0) - t * h(2, 0)) * inv), std::abs((h(1, 1) - t * h(2, 1)) * inv));
  const auto texture = [&] {
    const RipMap& map = *surface.texture;
    return map.sample(map.blend(static_cast<float>(s_span * kTexelsPerMetre),
                                static_cast<float>(t_span * kTexelsPerMetre)),
                      static_cast<float>(s * kTexelsPerMetre - surface.texel_origin.x),
                      static_cast<float>(-t * kTexelsPerMetre - surface.texel_origin.y));
  };
  if (surface.placed.empty()) return texture();
  // The decals whose left edge lies within the widest one's width before s, laid over the wall
  // in their order: read from the last (topmost) down, and the wall only if it shows through.
  const auto first =
      std::lower_bound(surface.placed.begin(), surface.placed.end(), s - surface.widest - s_span,
                       [](const Surface::Placed& p, double at) { return p.s0 < at; });
  auto last = first;
  while (last != surface.placed.end() && last->s0 <= s + s_span) ++last;
  float value = 0, shows = 1;  // what the decals add, and how much of what is below shows
  for (auto d = last; d != first && shows > 0;) {
    --d;
    if (s > d->s1 + s_span || t > d->t_top + t_span) continue;
    const Picture& picture = pictures_[static_cast<std::size_t>(d->picture)];
    const double ppm = picture.pixels_per_metre;
    const auto col = static_cast<float>((s - d->s0) * ppm);
    const auto row = static_cast<float>((d->t_top - t) * ppm);
    const RipMap::Blend blend =
        picture.coverage.blend(static_cast<float>(s_span * ppm), static_cast<float>(t_span * ppm));
    float coverage = 0, grey = 0;
    picture.coverage.samplePair(picture.grey, blend, col, row, coverage, grey);
    if (coverage <= 0) continue;
    value += shows * grey;
    shows = coverage >= 255 ? 0 : shows * (1 - coverage / 255);
  }
  return shows > 0 ? value + shows * texture() : value;
}

CanyonWorld::Exit CanyonWorld::View::exit(double u, double v) const {
  // The ray leaves the box through the surface it meets first: the largest nearness.
  Exit e;
  e.best_near = e.second_near = -1e300;
  for (std::size_t k = 0; k < nearness.size(); ++k) {
    const double near = nearness[k][0] * u + nearness[k][1] * v + nearness[k][2];
    if (near > e.best_near) {
      e.second = e.best;
      e.second_near = e.best_near;
      e.best = static_cast<int>(k);
      e.best_near = near;
    } else if (near > e.second_near) {
      e.second = static_cast<int>(k);
      e.second_near = near;
    }
  }
  return e;
}

cv::Mat CanyonWorld::render(const Pose& pose, const CameraIntrinsics& camera) const {
  const View v = view(pose, camera);
  cv::Mat frame(camera.height, camera.width, CV_8U);
  cv::parallel_for_(cv::Range(0, camera.height), [&](const cv::Range& rows) {
    for (int row = rows.start; row < rows.end; ++row) {
      std::uint8_t* out = frame.ptr<std::uint8_t>(row);
      for (int col = 0; col < camera.width; ++col) {
        const Exit e = v.exit(col, row);
        float value = shade(v, e.best, col, row);
        // Where two surfaces meet (equal nearness), the pixel covers both: blend by its distance
        // in pixels to that line, as a camera's pixel area does.
        if (e.second_near > 0) {
          const cv::Vec3d& a = v.nearness[static_cast<std::size_t>(e.best)];
          const cv::Vec3d& b = v.nearness[static_cast<std::size_t>(e.second)];
          const double slope_u = a[0] - b[0], slope_v = a[1] - b[1];
          const double distance =
              (e.best_near - e.second_near) / std::sqrt(slope_u * slope_u + slope_v * slope_v);
          if (distance < 0.5) {
            const auto w = static_cast<float>(0.5 + distance);
            value = w * value + (1 - w) * shade(v, e.second, col, row);
          }
        }
        out[col] = cv::saturate_cast<std::uint8_t>(value);
      }
    }
  });
  return frame;
}

cv::Mat CanyonWorld::surfaces(const Pose& pose, const CameraIntrinsics& camera) const {
  const View v = view(pose, camera);
  cv::Mat ids(camera.height, camera.width, CV_8U);
  for (int row = 0; row < camera.height; ++row) {
    for (int col = 0; col < camera.width; ++col)
      ids.at<std::uint8_t>(row, col) = static_cast<std::uint8_t>(v.exit(col, row).best);
  }
  return ids;
}

}  // namespace placedb::synthetic
