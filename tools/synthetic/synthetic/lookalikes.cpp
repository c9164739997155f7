#include "synthetic/lookalikes.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>

#include "placedb/error.h"
#include "synthetic/canyon.h"
#include "synthetic/seeded_random.h"
#include "synthetic/synthetic_sequence.h"

namespace placedb::synthetic {
namespace {

constexpr double kPixelsPerMetre = 160;
// The poster is drawn at kPixelsPerMetre and laid at this density: 1.2 x 0.73 m, an A0 sheet or
// the side of a newspaper stand, a metre to the left of the walk.
constexpr double kPosterPixelsPerMetre = 240;
constexpr double kPosterSide = 1.0;
// Upright pictures are seen from a metre or two in the canyon scenes: finer than the ground's.
constexpr double kUprightPixelsPerMetre = 256;
constexpr std::uint64_t kPosterSalt = 0x9057e7;

// A printed poster or the side of a newspaper stand: large lettering, a logo and a frame,
// 1.8 x 1.1 m. Its lettering gives the strongest corners in view, as printed matter does.
cv::Mat posterPicture(std::uint64_t seed) {
  const int w = static_cast<int>(1.8 * kPixelsPerMetre),
            h = static_cast<int>(1.1 * kPixelsPerMetre);
  cv::Mat p(h, w, CV_8U, cv::Scalar(232));
  cv::rectangle(p, cv::Rect(0, 0, w, h), cv::Scalar(20), 8);
  SeededRandom rng(hashOf(seed, kPosterSalt));
  const int fonts[] = {cv::FONT_HERSHEY_DUPLEX, cv::FONT_HERSHEY_TRIPLEX, cv::FONT_HERSHEY_COMPLEX};
  int y = 44;
  for (int line = 0; line < 3; ++line) {
    std::string word;
    const int letters = rng.intIn(5, 8);
    for (int k = 0; k < letters; ++k) word += static_cast<char>('A' + rng.intIn(0, 25));
    cv::putText(p, word, cv::Point(16 + rng.intIn(0, 20), y), fonts[line], 1.3,
                cv::Scalar(line == 1 ? 90 : 15), line == 0 ? 4 : 3, cv::LINE_AA);
    y += 46;
  }
  cv::circle(p, cv::Point(w - 52, 50), 30, cv::Scalar(20), cv::FILLED, cv::LINE_AA);
  cv::circle(p, cv::Point(w - 52, 50), 14, cv::Scalar(232), cv::FILLED, cv::LINE_AA);
  cv::rectangle(p, cv::Rect(w - 90, h - 40, 70, 18), cv::Scalar(40), cv::FILLED);
  return p;
}

// A stretch of corridor wall laid on the floor: a door (panel, window slot, handle, kick plate)
// and a bank of three lockers (vents, handles, number plates), 2.4 x 1.2 m. Identical copies
// repeat along the corridor, as real ones do.
cv::Mat corridorPicture() {
  const int w = static_cast<int>(2.4 * kPixelsPerMetre),
            h = static_cast<int>(1.2 * kPixelsPerMetre);
  cv::Mat p(h, w, CV_8U, cv::Scalar(150));
  // The door, on the left: dark panel in a light frame.
  const cv::Rect door(12, 10, 112, h - 20);
  cv::rectangle(p, door, cv::Scalar(225), cv::FILLED);
  cv::rectangle(p, door - cv::Point(-8, -8) - cv::Size(16, 16), cv::Scalar(55), cv::FILLED);
  cv::rectangle(p, cv::Rect(door.x + 36, door.y + 20, 40, 60), cv::Scalar(235), cv::FILLED);
  cv::rectangle(p, cv::Rect(door.x + 88, door.y + 100, 12, 26), cv::Scalar(240), cv::FILLED);
  cv::rectangle(p, cv::Rect(door.x + 12, door.y + door.height - 34, 88, 20), cv::Scalar(200),
                cv::FILLED);
  // The lockers, on the right.
  for (int k = 0; k < 3; ++k) {
    const cv::Rect locker(150 + k * 78, 12, 70, h - 24);
    cv::rectangle(p, locker, cv::Scalar(95), cv::FILLED);
    cv::rectangle(p, locker, cv::Scalar(30), 3);
    for (int v = 0; v < 4; ++v)
      cv::rectangle(p, cv::Rect(locker.x + 14, locker.y + 14 + v * 12, 42, 5), cv::Scalar(20),
                    cv::FILLED);
    cv::rectangle(p, cv::Rect(locker.x + 52, locker.y + 90, 8, 30), cv::Scalar(215), cv::FILLED);
    cv::rectangle(p, cv::Rect(locker.x + 20, locker.y + 70, 26, 12), cv::Scalar(230), cv::FILLED);
  }
  return p;
}

Error unknownKind(const std::string& kind) {
  return Error(
      ErrorCode::kInvalidArgument,
      "synthetic sequence: lookalike must be \"none\", \"poster\" or \"corridor\", not \"" + kind +
          "\"");
}

// Draws on an upright picture in metres, x from its left edge, z up from its bottom edge.
class UprightCanvas {
 public:
  UprightCanvas(double width, double height) {
    picture_.pixels_per_metre = kUprightPixelsPerMetre;
    const cv::Size size(static_cast<int>(std::lround(width * kUprightPixelsPerMetre)),
                        static_cast<int>(std::lround(height * kUprightPixelsPerMetre)));
    picture_.grey = cv::Mat(size, CV_8U, cv::Scalar(0));
    picture_.mask = cv::Mat(size, CV_8U, cv::Scalar(0));
  }
  cv::Rect rect(double x, double z, double w, double h) const {
    const double k = kUprightPixelsPerMetre;
    const int left = static_cast<int>(std::lround(x * k));
    const int top = static_cast<int>(std::lround(picture_.grey.rows - (z + h) * k));
    return {left, top, static_cast<int>(std::lround(w * k)), static_cast<int>(std::lround(h * k))};
  }
  // A filled box that covers the wall.
  void solid(double x, double z, double w, double h, int grey) {
    const cv::Rect r = rect(x, z, w, h);
    cv::rectangle(picture_.grey, r, cv::Scalar(grey), cv::FILLED);
    cv::rectangle(picture_.mask, r, cv::Scalar(255), cv::FILLED);
  }
  // An outline or mark on what is already covered.
  void line(double x, double z, double w, double h, int grey, int thickness) {
    cv::rectangle(picture_.grey, rect(x, z, w, h), cv::Scalar(grey), thickness);
  }
  cv::Mat& grey() { return picture_.grey; }
  std::shared_ptr<const UprightPicture> done() {
    return std::make_shared<const UprightPicture>(std::move(picture_));
  }

 private:
  UprightPicture picture_;
};

// A stretch of corridor wall at its real size, 2.8 x 2.2 m: a door (1.0 x 2.1 m, in a light
// frame, with a glass slot, a lever handle and a kick plate) and a bank of three lockers
// (0.4 x 1.8 m on a plinth, with vents, handles and number plates). The wall shows between them.
// Identical copies repeat along the corridor, as real ones do.
std::shared_ptr<const UprightPicture> uprightCorridorPicture() {
  UprightCanvas c(2.8, 2.2);
  // The door: frame, panel, glass slot with a dark edge, handle and its rose, kick plate.
  c.solid(0.02, 0.0, 1.16, 2.18, 215);
  c.solid(0.08, 0.0, 1.0, 2.1, 72);
  c.solid(0.68, 1.1, 0.18, 0.7, 225);
  c.line(0.68, 1.1, 0.18, 0.7, 30, 5);
  c.solid(0.16, 0.98, 0.05, 0.09, 205);
  c.solid(0.16, 1.02, 0.16, 0.03, 235);
  c.solid(0.14, 0.02, 0.88, 0.26, 175);
  // The lockers on their plinth.
  c.solid(1.45, 0.0, 1.26, 0.1, 45);
  for (int k = 0; k < 3; ++k) {
    const double x = 1.46 + 0.42 * k;
    c.solid(x, 0.1, 0.4, 1.8, 120);
    c.line(x, 0.1, 0.4, 1.8, 28, 4);
    for (int v = 0; v < 5; ++v) c.solid(x + 0.09, 1.66 - 0.06 * v, 0.22, 0.025, 25);
    c.solid(x + 0.32, 0.95, 0.035, 0.22, 225);
    c.solid(x + 0.12, 1.3, 0.16, 0.07, 235);
    c.line(x + 0.12, 1.3, 0.16, 0.07, 40, 2);
  }
  return c.done();
}

// A poster or the face of a newspaper stand at its real size, 1.0 x 1.4 m: a title in large
// lettering, lines of smaller print, a logo, a picture block and a price tag. Printed matter gives
// the strongest corners in view.
std::shared_ptr<const UprightPicture> uprightPosterPicture(std::uint64_t seed) {
  UprightCanvas c(1.0, 1.4);
  c.solid(0, 0, 1.0, 1.4, 236);
  c.line(0, 0, 1.0, 1.4, 18, 10);
  cv::Mat& p = c.grey();
  SeededRandom rng(hashOf(seed, kPosterSalt, 1));
  const auto word = [&rng](int shortest, int longest) {
    std::string w;
    const int letters = rng.intIn(shortest, longest);
    for (int k = 0; k < letters; ++k) w += static_cast<char>('A' + rng.intIn(0, 25));
    return w;
  };
  cv::putText(p, word(4, 6), cv::Point(18, 70), cv::FONT_HERSHEY_TRIPLEX, 1.6, cv::Scalar(15), 4,
              cv::LINE_AA);
  cv::circle(p, cv::Point(p.cols - 40, 110), 24, cv::Scalar(20), cv::FILLED, cv::LINE_AA);
  cv::circle(p, cv::Point(p.cols - 40, 110), 10, cv::Scalar(236), cv::FILLED, cv::LINE_AA);
  // The picture block: a dark square with a light disc and a bar across it.
  const cv::Rect block = c.rect(0.08, 0.62, 0.55, 0.42);
  cv::rectangle(p, block, cv::Scalar(60), cv::FILLED);
  cv::circle(p, (block.tl() + block.br()) / 2, block.height / 3, cv::Scalar(200), cv::FILLED,
             cv::LINE_AA);
  cv::rectangle(p, cv::Rect(block.x, block.y + block.height * 2 / 3, block.width, 12),
                cv::Scalar(140), cv::FILLED);
  int y = c.rect(0, 0.5, 0, 0).y;
  for (int line = 0; line < 4; ++line) {
    cv::putText(p, word(5, 8) + " " + word(2, 4), cv::Point(18, y), cv::FONT_HERSHEY_DUPLEX,
                line == 0 ? 0.9 : 0.7, cv::Scalar(line == 0 ? 15 : 70), 2, cv::LINE_AA);
    y += line == 0 ? 40 : 30;
  }
  const cv::Rect tag = c.rect(0.66, 0.06, 0.28, 0.12);
  cv::rectangle(p, tag, cv::Scalar(25), cv::FILLED);
  cv::putText(p, std::to_string(rng.intIn(1, 9)) + "." + std::to_string(rng.intIn(10, 99)),
              tag.tl() + cv::Point(8, tag.height - 8), cv::FONT_HERSHEY_SIMPLEX, 0.8,
              cv::Scalar(236), 2, cv::LINE_AA);
  return c.done();
}

// The ground point `ahead` metres in front of the camera at `pose` and `side` metres to its left.
cv::Point2d inFrontOf(const Pose& pose, double ahead, double side) {
  const double c = std::cos(pose.heading), s = std::sin(pose.heading);
  return {pose.x + ahead * c - side * s, pose.y + ahead * s + side * c};
}

// Ground metres to picture pixels.
cv::Matx33d groundToPicture(const Decal& d) {
  const double c = std::cos(d.angle), s = std::sin(d.angle), k = d.pixels_per_metre;
  const double cx = 0.5 * d.picture->cols, cy = 0.5 * d.picture->rows;
  // Picture +x along the angle, picture +v against its left normal (rows grow away from it).
  const cv::Matx33d rotate(c, s, 0,   //
                           s, -c, 0,  //
                           0, 0, 1);
  const cv::Matx33d shift(1, 0, -d.centre.x, 0, 1, -d.centre.y, 0, 0, 1);
  const cv::Matx33d scale(k, 0, cx, 0, k, cy, 0, 0, 1);
  return scale * rotate * shift;
}

}  // namespace

std::vector<Decal> placeLookalikes(const SyntheticOptions& o, const std::vector<Pose>& poses) {
  std::vector<Decal> decals;
  if (o.lookalike == "none" || poses.empty()) return decals;
  // Objects stand where the camera looks: its optical axis meets the ground this far ahead.
  const double ahead = o.camera_height / std::tan(o.pitch_degrees * CV_PI / 180.0);
  if (o.lookalike == "poster") {
    // One picture, two places: a third of the way along the route and lookalike_gap frames on.
    auto picture = std::make_shared<const cv::Mat>(posterPicture(o.seed));
    const int first = static_cast<int>(poses.size()) / 3;
    for (int frame : {first, first + o.lookalike_gap}) {
      if (frame >= static_cast<int>(poses.size())) break;
      const Pose& p = poses[static_cast<std::size_t>(frame)];
      decals.push_back(
          {picture, kPosterPixelsPerMetre, inFrontOf(p, ahead, kPosterSide), p.heading});
    }
    return decals;
  }
  if (o.lookalike == "corridor") {
    auto picture = std::make_shared<const cv::Mat>(corridorPicture());
    const double side = 0.5 * 1.2 + 0.9;  // the walls of a corridor 1.8 m wide
    double next = 0;
    double travelled = 0;
    for (std::size_t i = 0; i < poses.size(); ++i) {
      if (i > 0) travelled += std::hypot(poses[i].x - poses[i - 1].x, poses[i].y - poses[i - 1].y);
      if (travelled < next) continue;
      next += o.lookalike_pitch;
      for (double sign : {1.0, -1.0})
        decals.push_back({picture, kPixelsPerMetre, inFrontOf(poses[i], ahead, sign * side),
                          poses[i].heading + (sign > 0 ? 0 : CV_PI)});
    }
    return decals;
  }
  throw unknownKind(o.lookalike);
}

std::vector<WallDecal> placeWallLookalikes(const SyntheticOptions& o,
                                           const std::vector<Pose>& poses, const CanyonBox& box) {
  std::vector<WallDecal> decals;
  if (o.lookalike == "none" || poses.empty()) return decals;
  if (o.lookalike == "poster") {
    // On the right-hand wall at eye level, where the camera of each frame sees it a quarter of
    // the field of view off its axis: both places are lookalike_gap frames of walk apart.
    auto picture = uprightPosterPicture(o.seed);
    const double across = -box.y_right;
    const double ahead = across / std::tan(o.hfov_degrees * CV_PI / 180.0 / 4);
    const int first = static_cast<int>(poses.size()) / 3;
    for (int frame : {first, first + o.lookalike_gap}) {
      if (frame >= static_cast<int>(poses.size())) break;
      const double x = poses[static_cast<std::size_t>(frame)].x + ahead;
      decals.push_back({picture, WallSide::kRight, x, 1.5 - 0.5 * picture->height()});
    }
    return decals;
  }
  if (o.lookalike == "corridor") {
    auto picture = uprightCorridorPicture();
    const double half = 0.5 * picture->width();
    for (double x = box.x_start + half + 0.5; x + half < box.x_end; x += o.lookalike_pitch) {
      for (WallSide side : {WallSide::kLeft, WallSide::kRight})
        decals.push_back({picture, side, x, 0});
    }
    return decals;
  }
  throw unknownKind(o.lookalike);
}

void paintDecals(cv::Mat& frame, const std::vector<Decal>& decals, const Pose& pose,
                 const CameraIntrinsics& camera) {
  if (decals.empty()) return;
  const std::array<cv::Point2d, 4> footprint = groundFootprint(pose, camera);
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const auto& g : footprint) {
    x0 = std::min(x0, g.x);
    x1 = std::max(x1, g.x);
    y0 = std::min(y0, g.y);
    y1 = std::max(y1, g.y);
  }
  const cv::Matx33d image_to_ground = imageToGround(pose, camera);
  for (const Decal& d : decals) {
    const double reach = 0.5 * std::hypot(d.picture->cols, d.picture->rows) / d.pixels_per_metre;
    if (d.centre.x + reach < x0 || d.centre.x - reach > x1 || d.centre.y + reach < y0 ||
        d.centre.y - reach > y1)
      continue;
    // Each image pixel looks up the picture through the ground (every pixel sees the ground,
    // so the map is defined everywhere, unlike the picture-to-image direction).
    const cv::Matx33d image_to_picture = groundToPicture(d) * image_to_ground;
    cv::Mat painted, coverage;
    cv::warpPerspective(*d.picture, painted, image_to_picture, frame.size(),
                        cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_CONSTANT);
    const cv::Mat solid(d.picture->size(), CV_8U, cv::Scalar(255));
    cv::warpPerspective(solid, coverage, image_to_picture, frame.size(),
                        cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_CONSTANT);
    for (int v = 0; v < frame.rows; ++v) {
      std::uint8_t* out = frame.ptr<std::uint8_t>(v);
      const std::uint8_t* in = painted.ptr<std::uint8_t>(v);
      const std::uint8_t* a = coverage.ptr<std::uint8_t>(v);
      for (int u = 0; u < frame.cols; ++u)
        // `painted` is the picture already weighed by its coverage at the edges.
        if (a[u])
          out[u] = static_cast<std::uint8_t>(std::min(255, out[u] * (255 - a[u]) / 255 + in[u]));
    }
  }
}

}  // namespace placedb::synthetic
