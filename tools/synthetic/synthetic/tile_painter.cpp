#include "synthetic/tile_painter.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "synthetic/seeded_random.h"

namespace placedb::synthetic {
namespace {

constexpr std::uint64_t kShapeSalt = 0x5a4e11;
constexpr std::uint64_t kNoiseSalt = 0x4015e;
constexpr int kShift = 4;  // sub-texel precision of OpenCV's drawing calls
constexpr double kShiftScale = 1 << kShift;

enum class ShapeKind {
  kEllipse,
  kRing,
  kRectangle,
  kFrame,
  kPolygon,
  kStroke,
  kBlob,
  kGlyphs,
  kGradient
};

struct Shape {
  ShapeKind kind = ShapeKind::kEllipse;
  double depth = 0;     // paint order, the same in every tile
  cv::Point2d centre;   // global texels
  double reach = 0;     // no texel farther than this from the centre is painted
  double a = 0, b = 0;  // half sizes
  double angle = 0;     // radians
  int grey = 0, grey2 = 0;
  int thickness = 1;
  std::vector<cv::Point2d> vertices;  // relative to the centre
  std::string text;
  int font = cv::FONT_HERSHEY_SIMPLEX;
  double font_scale = 1;
};

int contrastingGrey(SeededRandom& rng) {
  // Favour darks and lights over mid-greys: stronger edges for detectors.
  const double u = rng.uniform();
  const double pushed = u < 0.5 ? 0.5 * std::pow(2 * u, 0.6) : 1 - 0.5 * std::pow(2 * (1 - u), 0.6);
  return static_cast<int>(8 + 240 * pushed);
}

Shape makeShape(SeededRandom& rng, int layer, cv::Point2d centre, double size) {
  Shape s;
  s.centre = centre;
  s.depth = layer + rng.uniform();
  s.grey = contrastingGrey(rng);
  s.grey2 = contrastingGrey(rng);
  s.angle = rng.uniform(0, CV_PI);
  s.a = size;
  s.b = size * rng.uniform(0.3, 1.0);
  s.thickness = std::max(1, static_cast<int>(size * rng.uniform(0.08, 0.25)));
  s.reach = size + s.thickness + 2;

  const double pick = rng.uniform();
  if (layer == 0) {  // large, low structures
    s.kind = pick < 0.3   ? ShapeKind::kGradient
             : pick < 0.6 ? ShapeKind::kPolygon
             : pick < 0.8 ? ShapeKind::kEllipse
                          : ShapeKind::kRectangle;
  } else {
    static const ShapeKind kinds[] = {
        ShapeKind::kEllipse, ShapeKind::kRing,    ShapeKind::kRectangle,
        ShapeKind::kFrame,   ShapeKind::kPolygon, ShapeKind::kStroke,
        ShapeKind::kBlob,    ShapeKind::kGlyphs,  ShapeKind::kBlob};
    s.kind = kinds[rng.intIn(0, 8)];
  }

  if (s.kind == ShapeKind::kPolygon) {
    const int corners = rng.intIn(3, 7);
    std::vector<double> angles;
    for (int k = 0; k < corners; ++k) angles.push_back(rng.uniform(0, 2 * CV_PI));
    std::sort(angles.begin(), angles.end());
    for (double t : angles) {
      const double r = size * rng.uniform(0.45, 1.0);
      s.vertices.emplace_back(r * std::cos(t), r * std::sin(t));
    }
  } else if (s.kind == ShapeKind::kStroke) {
    cv::Point2d p(0, 0);
    double heading = rng.uniform(0, 2 * CV_PI);
    const int points = rng.intIn(2, 5);
    const double step = size / points;
    s.thickness = std::max(1, static_cast<int>(rng.uniform(1, 1 + size * 0.12)));
    for (int k = 0; k < points; ++k) {
      s.vertices.push_back(p);
      heading += rng.uniform(-1.3, 1.3);
      p += cv::Point2d(std::cos(heading), std::sin(heading)) * (2 * step);
    }
    cv::Point2d mean(0, 0);
    for (const auto& v : s.vertices) mean += v;
    mean *= 1.0 / s.vertices.size();
    s.reach = 0;
    for (auto& v : s.vertices) {
      v -= mean;
      s.reach = std::max(s.reach, std::hypot(v.x, v.y));
    }
    s.reach += s.thickness + 2;
  } else if (s.kind == ShapeKind::kGlyphs) {
    static const char kAlphabet[] = "ABCDEFGHJKLMNPRSTUVWXYZ0123456789#&%@+=";
    const int length = rng.intIn(1, 4);
    for (int k = 0; k < length; ++k) s.text += kAlphabet[rng.intIn(0, sizeof(kAlphabet) - 2)];
    static const int fonts[] = {cv::FONT_HERSHEY_SIMPLEX, cv::FONT_HERSHEY_DUPLEX,
                                cv::FONT_HERSHEY_COMPLEX, cv::FONT_HERSHEY_TRIPLEX};
    s.font = fonts[rng.intIn(0, 3)];
    s.thickness = rng.intIn(1, 3);
    int baseline = 0;
    const cv::Size unit = cv::getTextSize(s.text, s.font, 1.0, s.thickness, &baseline);
    s.font_scale = std::clamp(2.0 * size / std::max(1, unit.width), 0.35, 3.0);
    s.reach = s.font_scale * std::hypot(unit.width, unit.height + baseline) + s.thickness + 2;
  } else if (s.kind == ShapeKind::kBlob) {
    s.reach = 2.5 * s.a;
  } else if (s.kind == ShapeKind::kRectangle || s.kind == ShapeKind::kFrame ||
             s.kind == ShapeKind::kGradient) {
    s.reach = std::hypot(s.a, s.b) + s.thickness + 2;
  }
  return s;
}

// The shapes whose centres lie in one tile, bounded so they reach at most one tile further.
std::vector<Shape> shapesOfTile(std::uint64_t seed, int tile_x, int tile_y, int tile_texels) {
  SeededRandom rng(hashOf(seed, kShapeSalt, tile_x, tile_y));
  const double density = rng.uniform(0.7, 1.3);
  const cv::Point2d origin(static_cast<double>(tile_x) * tile_texels,
                           static_cast<double>(tile_y) * tile_texels);
  // (layer, count per tile, smallest and largest half size in texels)
  struct Band {
    int layer, count;
    double smallest, largest;
  };
  const Band bands[] = {{0, 6, 35, 100}, {1, 40, 9, 32}, {2, 90, 2.5, 9}};
  std::vector<Shape> shapes;
  for (const Band& band : bands) {
    const int count = static_cast<int>(std::lround(band.count * density));
    for (int k = 0; k < count; ++k) {
      const cv::Point2d centre =
          origin + cv::Point2d(rng.uniform(0, tile_texels), rng.uniform(0, tile_texels));
      shapes.push_back(
          makeShape(rng, band.layer, centre, rng.logUniform(band.smallest, band.largest)));
      shapes.back().reach = std::min(shapes.back().reach, 0.99 * tile_texels);
    }
  }
  return shapes;
}

cv::Point fixedPoint(cv::Point2d p) {
  return cv::Point(static_cast<int>(std::lround(p.x * kShiftScale)),
                   static_cast<int>(std::lround(p.y * kShiftScale)));
}

// Pixels of the tile that a per-texel painter must visit for a shape.
cv::Rect reachRect(const Shape& s, cv::Point2d local, const cv::Size& size) {
  const cv::Rect box(static_cast<int>(std::floor(local.x - s.reach)),
                     static_cast<int>(std::floor(local.y - s.reach)),
                     static_cast<int>(2 * s.reach + 2), static_cast<int>(2 * s.reach + 2));
  return box & cv::Rect(0, 0, size.width, size.height);
}

void paintBlob(cv::Mat& tile, const Shape& s, cv::Point2d local) {
  const cv::Rect box = reachRect(s, local, tile.size());
  const double inv_two_sigma2 = 1.0 / (2 * s.a * s.a * 0.5);
  for (int row = box.y; row < box.y + box.height; ++row) {
    auto* line = tile.ptr<std::uint8_t>(row);
    for (int col = box.x; col < box.x + box.width; ++col) {
      const double dx = col - local.x, dy = row - local.y;
      const double weight = std::exp(-(dx * dx + dy * dy) * inv_two_sigma2);
      line[col] = cv::saturate_cast<std::uint8_t>(line[col] + weight * (s.grey - line[col]));
    }
  }
}

void paintGradient(cv::Mat& tile, const Shape& s, cv::Point2d local) {
  const cv::Rect box = reachRect(s, local, tile.size());
  const double c = std::cos(s.angle), sn = std::sin(s.angle);
  for (int row = box.y; row < box.y + box.height; ++row) {
    auto* line = tile.ptr<std::uint8_t>(row);
    for (int col = box.x; col < box.x + box.width; ++col) {
      const double dx = col - local.x, dy = row - local.y;
      const double along = dx * c + dy * sn, across = -dx * sn + dy * c;
      if (std::abs(along) > s.a || std::abs(across) > s.b) continue;
      const double t = 0.5 + 0.5 * along / s.a;
      line[col] = cv::saturate_cast<std::uint8_t>(s.grey + t * (s.grey2 - s.grey));
    }
  }
}

std::vector<cv::Point> rotatedCorners(const Shape& s, cv::Point2d local) {
  const double c = std::cos(s.angle), sn = std::sin(s.angle);
  std::vector<cv::Point> corners;
  const double signs[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
  for (const auto& sign : signs) {
    const double u = sign[0] * s.a, v = sign[1] * s.b;
    corners.push_back(fixedPoint(local + cv::Point2d(u * c - v * sn, u * sn + v * c)));
  }
  return corners;
}

void paintShape(cv::Mat& tile, const Shape& s, cv::Point2d local) {
  const cv::Scalar grey(s.grey);
  const double degrees = s.angle * 180.0 / CV_PI;
  const cv::Size axes(static_cast<int>(s.a * kShiftScale), static_cast<int>(s.b * kShiftScale));
  switch (s.kind) {
    case ShapeKind::kEllipse:
      cv::ellipse(tile, fixedPoint(local), axes, degrees, 0, 360, grey, cv::FILLED, cv::LINE_AA,
                  kShift);
      break;
    case ShapeKind::kRing:
      cv::ellipse(tile, fixedPoint(local), axes, degrees, 0, 360, grey, s.thickness, cv::LINE_AA,
                  kShift);
      break;
    case ShapeKind::kRectangle:
      cv::fillConvexPoly(tile, rotatedCorners(s, local), grey, cv::LINE_AA, kShift);
      break;
    case ShapeKind::kFrame: {
      const std::vector<std::vector<cv::Point>> outline{rotatedCorners(s, local)};
      cv::polylines(tile, outline, true, grey, s.thickness, cv::LINE_AA, kShift);
      break;
    }
    case ShapeKind::kPolygon:
    case ShapeKind::kStroke: {
      std::vector<std::vector<cv::Point>> outline(1);
      for (const auto& v : s.vertices) outline[0].push_back(fixedPoint(local + v));
      if (s.kind == ShapeKind::kPolygon) {
        cv::fillPoly(tile, outline, grey, cv::LINE_AA, kShift);
      } else {
        cv::polylines(tile, outline, false, grey, s.thickness, cv::LINE_AA, kShift);
      }
      break;
    }
    case ShapeKind::kBlob:
      paintBlob(tile, s, local);
      break;
    case ShapeKind::kGradient:
      paintGradient(tile, s, local);
      break;
    case ShapeKind::kGlyphs: {
      int baseline = 0;
      const cv::Size extent = cv::getTextSize(s.text, s.font, s.font_scale, s.thickness, &baseline);
      // Integer origin in global texels, so every tile rasterises the glyphs identically.
      const cv::Point origin(static_cast<int>(std::lround(local.x - 0.5 * extent.width)),
                             static_cast<int>(std::lround(local.y + 0.5 * extent.height)));
      cv::putText(tile, s.text, origin, s.font, s.font_scale, grey, s.thickness, cv::LINE_AA);
      break;
    }
  }
}

// Catmull-Rom taps mapping lattice values to texels along one axis of the tile: texel k blends
// lattice entries first[k] .. first[k] + 3 (relative to first_node) with weights[k].
struct AxisTaps {
  std::int64_t first_node = 0;
  int nodes = 0;
  std::vector<int> first;
  std::vector<std::array<float, 4>> weights;
};

AxisTaps axisTaps(std::int64_t first_texel, int texels, double cell) {
  AxisTaps taps;
  taps.first_node = static_cast<std::int64_t>(std::floor(first_texel / cell)) - 1;
  const auto last_node =
      static_cast<std::int64_t>(std::floor((first_texel + texels - 1) / cell)) + 2;
  taps.nodes = static_cast<int>(last_node - taps.first_node + 1);
  for (int k = 0; k < texels; ++k) {
    const double u = (first_texel + k) / cell;
    const double node = std::floor(u);
    const double t = u - node;
    const double t2 = t * t, t3 = t2 * t;
    taps.first.push_back(static_cast<int>(static_cast<std::int64_t>(node) - 1 - taps.first_node));
    taps.weights.push_back({static_cast<float>(0.5 * (-t3 + 2 * t2 - t)),
                            static_cast<float>(0.5 * (3 * t3 - 5 * t2 + 2)),
                            static_cast<float>(0.5 * (-3 * t3 + 4 * t2 + t)),
                            static_cast<float>(0.5 * (t3 - t2))});
  }
  return taps;
}

// Adds one octave of value noise, continuous across tiles because the lattice is global.
// Separable: lattice rows are first interpolated along x, then those rows along y.
void addValueNoise(cv::Mat& tile32, std::uint64_t seed, std::uint64_t salt, std::int64_t x0,
                   std::int64_t y0, double cell, double amplitude) {
  const AxisTaps along_x = axisTaps(x0, tile32.cols, cell);
  const AxisTaps along_y = axisTaps(y0, tile32.rows, cell);
  cv::Mat rows(along_y.nodes, tile32.cols, CV_32F);
  std::vector<float> lattice_row(along_x.nodes);
  for (int r = 0; r < along_y.nodes; ++r) {
    for (int c = 0; c < along_x.nodes; ++c) {
      const double v =
          2.0 * unitOf(hashOf(seed, salt, along_x.first_node + c, along_y.first_node + r)) - 1.0;
      lattice_row[c] = static_cast<float>(amplitude * v);
    }
    auto* out = rows.ptr<float>(r);
    for (int k = 0; k < tile32.cols; ++k) {
      const float* in = &lattice_row[along_x.first[k]];
      const auto& w = along_x.weights[k];
      out[k] = w[0] * in[0] + w[1] * in[1] + w[2] * in[2] + w[3] * in[3];
    }
  }
  for (int k = 0; k < tile32.rows; ++k) {
    const auto& w = along_y.weights[k];
    const int first = along_y.first[k];
    const float* in[4] = {rows.ptr<float>(first), rows.ptr<float>(first + 1),
                          rows.ptr<float>(first + 2), rows.ptr<float>(first + 3)};
    auto* out = tile32.ptr<float>(k);
    for (int col = 0; col < tile32.cols; ++col) {
      out[col] += w[0] * in[0][col] + w[1] * in[1][col] + w[2] * in[2][col] + w[3] * in[3][col];
    }
  }
}

}  // namespace

cv::Mat paintTile(std::uint64_t seed, int tile_x, int tile_y, int tile_texels) {
  const std::int64_t x0 = static_cast<std::int64_t>(tile_x) * tile_texels;
  const std::int64_t y0 = static_cast<std::int64_t>(tile_y) * tile_texels;

  // Background: broad tone changes down to fine grain.
  cv::Mat ground(tile_texels, tile_texels, CV_32F, cv::Scalar(125));
  const double cells[] = {700, 260, 100, 40, 14, 5};
  const double amplitudes[] = {45, 30, 18, 10, 7, 5};
  for (int octave = 0; octave < 6; ++octave) {
    addValueNoise(ground, seed, kNoiseSalt + octave, x0, y0, cells[octave], amplitudes[octave]);
  }
  cv::Mat tile;
  ground.convertTo(tile, CV_8U);

  std::vector<Shape> shapes;
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      for (Shape& s : shapesOfTile(seed, tile_x + dx, tile_y + dy, tile_texels)) {
        const cv::Point2d local =
            s.centre - cv::Point2d(static_cast<double>(x0), static_cast<double>(y0));
        const bool reaches = local.x + s.reach >= 0 && local.y + s.reach >= 0 &&
                             local.x - s.reach < tile_texels && local.y - s.reach < tile_texels;
        if (reaches) shapes.push_back(std::move(s));
      }
    }
  }
  std::sort(shapes.begin(), shapes.end(),
            [](const Shape& a, const Shape& b) { return a.depth < b.depth; });
  for (const Shape& s : shapes) {
    paintShape(tile, s, s.centre - cv::Point2d(static_cast<double>(x0), static_cast<double>(y0)));
  }

  // Grain over everything: worn, dirty surfaces rather than flat vector art.
  cv::Mat grain(tile_texels, tile_texels, CV_32F, cv::Scalar(0));
  addValueNoise(grain, seed, kNoiseSalt + 100, x0, y0, 2.5, 7);
  cv::Mat painted;
  tile.convertTo(painted, CV_32F);
  painted += grain;
  painted.convertTo(tile, CV_8U);
  return tile;
}

}  // namespace placedb::synthetic
