#include "features/surf_detector.h"

#include <cmath>
#include <cstddef>
#include <cstdint>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#endif

#include "features/cpu_support.h"
#include "features/parallel_for.h"

namespace placedb {
namespace {

// The determinant-of-Hessian map of one filter size, sampled every `step` pixels.
struct ResponseLayer {
  int filter_size = 0;
  int step = 1;
  int rows = 0, cols = 0;
  // Cells [first, last] (inclusive) in each direction are those where the filter fits.
  int first_col = 0, last_col = -1, first_row = 0, last_row = -1;
  std::vector<float> det;  // rows x cols; undefined where the filter does not fit

  float at(int r, int c) const { return det[static_cast<std::size_t>(r) * cols + c]; }
};

constexpr int kRowsPerTask = 16;
// Interpolated extrema further than this (in samples) from their sample belong to a neighbour.
constexpr double kMaxInterpolationOffset = 0.5;
long long sumOfSquares(int from, int to) {  // from^2 + ... + to^2, 0 <= from <= to
  auto upTo = [](long long n) { return n * (n + 1) * (2 * n + 1) / 6; };
  return upTo(to) - (from > 0 ? upTo(from - 1) : 0);
}

// The weight of Dxy in det = Dxx Dyy - (w Dxy)^2. The paper fixes w = 0.9, derived for the
// 9-pixel filter; but the Dxy boxes (lobe x lobe) shrink relative to the Dxx/Dyy lobes
// (lobe x (2 lobe - 1)) as filters grow, so a constant w lets oblique edges through at larger
// scales and makes the detector far less rotation invariant. Here w makes the box filters exact
// on quadratic intensity (x^2 / 2 and x y give Dxx and w Dxy equal to their true curvature times
// the same factor) at every filter size: 0.94 at 9 px, 1.25 at 15 px, 1.53 at 27 px.
float dxyWeight(int lobe) {
  const int lobe_half = (lobe - 1) / 2;
  // Dxx of x^2 / 2: (2 lobe - 1) rows x (outer lobes - 2 x middle lobe) sums of x^2 / 2.
  const long long outer = sumOfSquares(lobe_half + 1, lobe_half + lobe);
  const long long middle = 2 * sumOfSquares(1, lobe_half);
  const double dxx = (2.0 * lobe - 1.0) * (2.0 * outer - 2.0 * middle) / 2.0;
  // Dxy of x y: four boxes, each (1 + ... + lobe)^2.
  const double side_sum = lobe * (lobe + 1) / 2.0;
  const double dxy = 4.0 * side_sum * side_sum;
  return static_cast<float>(dxx / dxy);
}

// Sets `out` up for one filter size, reusing its buffer.
void makeLayer(const IntegralImage& integral, int octave, int layer, ResponseLayer& out) {
  out.filter_size = surfFilterSize(octave, layer);
  out.step = 1 << octave;
  out.cols = (integral.width() + out.step - 1) / out.step;
  out.rows = (integral.height() + out.step - 1) / out.step;
  const int half = (out.filter_size - 1) / 2;
  out.first_col = (half + out.step - 1) / out.step;
  out.first_row = out.first_col;
  out.last_col = integral.width() - 1 - half >= 0 ? (integral.width() - 1 - half) / out.step : -1;
  out.last_row = integral.height() - 1 - half >= 0 ? (integral.height() - 1 - half) / out.step : -1;
  // Samples where the filter does not fit are never read (extrema need the largest filter of
  // their octave to fit), so the buffer's earlier values may stay there. It never shrinks: a
  // small image's second search at twice the size would zero the regrown part every frame.
  const std::size_t cells = static_cast<std::size_t>(out.rows) * out.cols;
  if (out.det.size() < cells) out.det.resize(cells);
}

// The integral table read with a step: entry (x, y) sits in plane x mod step, at column
// x / step, so that as a filter's centre moves one step along a row, each of its corners moves
// one entry. For step 1 the table itself is the one plane.
struct SteppedTable {
  const std::uint32_t* base = nullptr;
  int step = 1;
  int width = 0;               // entries in a plane's row
  std::size_t plane_size = 0;  // entries in a plane

  // Where column x >= 0 of row 0 sits; row y's entry is width * y further, and entries x + step,
  // x + 2 step, ... follow it.
  std::size_t column(int x) const { return (x % step) * plane_size + x / step; }
};

SteppedTable steppedTable(const IntegralImage& integral, int step,
                          std::vector<std::uint32_t>& planes) {
  SteppedTable t;
  t.step = step;
  if (step == 1) {
    t.base = integral.data();
    t.width = integral.stride();
    t.plane_size = static_cast<std::size_t>(integral.height() + 1) * integral.stride();
    return t;
  }
  const int rows = integral.height() + 1;
  t.width = (integral.stride() + step - 1) / step;
  t.plane_size = static_cast<std::size_t>(rows) * t.width;
  if (planes.size() < t.plane_size * step) planes.resize(t.plane_size * step);  // as det's
  for (int residue = 0; residue < step; ++residue) {
    for (int y = 0; y < rows; ++y) {
      const std::uint32_t* from = integral.data() + static_cast<std::size_t>(y) * integral.stride();
      std::uint32_t* to =
          planes.data() + residue * t.plane_size + static_cast<std::size_t>(y) * t.width;
      for (int j = 0, x = residue; x < integral.stride(); ++j, x += step) to[j] = from[x];
    }
  }
  t.base = planes.data();
  return t;
}

// The three box filters of one filter size as 32 box corners relative to the filter's centre
// (bottom right, top right, bottom left, top left of each box), and their scales.
struct HessianBoxes {
  int dx[32], dy[32];
  float inv_lobe_area, dxy_weight;

  explicit HessianBoxes(int filter_size) {
    const int lobe = filter_size / 3, half = (filter_size - 1) / 2, lobe_half = (lobe - 1) / 2;
    // Boxes (left, top, right, bottom): pixels [x + left, x + right) x [y + top, y + bottom)
    // around centre (x, y). Dyy = three lobes stacked vertically (+1, -2, +1) = whole column -
    // 3 x middle lobe, Dxx the same across; Dxy = four lobe x lobe boxes around the centre, one
    // pixel apart: + - / - +.
    const int boxes[8][4] = {{-(lobe - 1), -half, lobe, half + 1},            // Dyy whole
                             {-(lobe - 1), -lobe_half, lobe, lobe_half + 1},  // Dyy middle
                             {-half, -(lobe - 1), half + 1, lobe},            // Dxx whole
                             {-lobe_half, -(lobe - 1), lobe_half + 1, lobe},  // Dxx middle
                             {-lobe, -lobe, 0, 0},                            // Dxy top left
                             {1, -lobe, lobe + 1, 0},                         // top right
                             {-lobe, 1, 0, lobe + 1},                         // bottom left
                             {1, 1, lobe + 1, lobe + 1}};                     // bottom right
    for (int b = 0; b < 8; ++b) {
      const int left = boxes[b][0], top = boxes[b][1], right = boxes[b][2], bottom = boxes[b][3];
      const int corners[4][2] = {{right, bottom}, {right, top}, {left, bottom}, {left, top}};
      for (int k = 0; k < 4; ++k) {
        dx[4 * b + k] = corners[k][0];
        dy[4 * b + k] = corners[k][1];
      }
    }
    // OpenCV's scale for Dxx and Dyy, so that Hessian thresholds keep their usual meaning.
    inv_lobe_area = 1.0f / static_cast<float>(lobe * (2 * lobe - 1));
    dxy_weight = dxyWeight(lobe);
  }

  // The responses of the filter whose corner k is the table entry p[k][c]. Box sums wrap like
  // the table itself; the int32 casts recover the exact signed values.
  void responses(const std::uint32_t* const* p, int c, float& dxx, float& dyy, float& dxy) const {
    const auto box = [&](int b) {
      return p[4 * b][c] - p[4 * b + 1][c] - p[4 * b + 2][c] + p[4 * b + 3][c];
    };
    const auto dyy_int = static_cast<std::int32_t>(box(0) - 3u * box(1));
    const auto dxx_int = static_cast<std::int32_t>(box(2) - 3u * box(3));
    const auto dxy_int = static_cast<std::int32_t>(box(4) + box(7) - box(5) - box(6));
    dxx = static_cast<float>(dxx_int) * inv_lobe_area;
    dyy = static_cast<float>(dyy_int) * inv_lobe_area;
    dxy = static_cast<float>(dxy_int) * inv_lobe_area * dxy_weight;
  }
};

// The determinant of the filter whose corner k is the table entry p[k][c].
inline float determinantAt(const std::uint32_t* const* p, int c, const HessianBoxes& h) {
  float dxx, dyy, dxy;
  h.responses(p, c, dxx, dyy, dxy);
  return dxx * dyy - dxy * dxy;
}

#if defined(__GNUC__) && defined(__x86_64__)
#define PLACEDB_LAYER_ROWS_AVX2 1
// determinantAt() of centres c .. c + 7: the same integer sums and the same float operations
// (AVX2 alone has no fused multiply-add to round differently), so the same determinants.
__attribute__((target("avx2"))) void determinantsAvx2(const std::uint32_t* const* p, int c, int end,
                                                      const HessianBoxes& h, float* out) {
  const __m256 inv_area = _mm256_set1_ps(h.inv_lobe_area);
  const __m256 weight = _mm256_set1_ps(h.dxy_weight);
  for (; c + 8 <= end; c += 8) {
    __m256i box[8];
    for (int b = 0; b < 8; ++b) {
      const std::uint32_t* const* q = p + 4 * b;
      box[b] = _mm256_add_epi32(
          _mm256_sub_epi32(
              _mm256_sub_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(q[0] + c)),
                               _mm256_loadu_si256(reinterpret_cast<const __m256i*>(q[1] + c))),
              _mm256_loadu_si256(reinterpret_cast<const __m256i*>(q[2] + c))),
          _mm256_loadu_si256(reinterpret_cast<const __m256i*>(q[3] + c)));
    }
    const __m256i dyy_int =
        _mm256_sub_epi32(box[0], _mm256_add_epi32(_mm256_slli_epi32(box[1], 1), box[1]));
    const __m256i dxx_int =
        _mm256_sub_epi32(box[2], _mm256_add_epi32(_mm256_slli_epi32(box[3], 1), box[3]));
    const __m256i dxy_int =
        _mm256_sub_epi32(_mm256_sub_epi32(_mm256_add_epi32(box[4], box[7]), box[5]), box[6]);
    const __m256 dxx = _mm256_mul_ps(_mm256_cvtepi32_ps(dxx_int), inv_area);
    const __m256 dyy = _mm256_mul_ps(_mm256_cvtepi32_ps(dyy_int), inv_area);
    const __m256 dxy = _mm256_mul_ps(_mm256_mul_ps(_mm256_cvtepi32_ps(dxy_int), inv_area), weight);
    _mm256_storeu_ps(out + c, _mm256_sub_ps(_mm256_mul_ps(dxx, dyy), _mm256_mul_ps(dxy, dxy)));
  }
  for (; c < end; ++c) out[c] = determinantAt(p, c, h);
}
#endif

// Determinants of rows [row_begin, row_end) of one layer (those where its filter fits).
void computeLayerRows(const SteppedTable& table, ResponseLayer& layer, int row_begin, int row_end) {
  const HessianBoxes h(layer.filter_size);
  const int r0 = std::max(row_begin, layer.first_row);
  const int r1 = std::min(row_end - 1, layer.last_row);
#if defined(PLACEDB_LAYER_ROWS_AVX2)
  static const bool avx2 = simdAllows(SimdLevel::kAvx2);
#endif
  const int count = layer.last_col - layer.first_col + 1;
  const int x0 = layer.first_col * layer.step;  // the first centre; its filter fits
  std::size_t columns[32];
  for (int k = 0; k < 32; ++k) columns[k] = table.column(x0 + h.dx[k]);
  for (int r = r0; r <= r1; ++r) {
    // p[k][i]: corner k of the filter centred on column first_col + i.
    const std::uint32_t* p[32];
    for (int k = 0; k < 32; ++k) {
      const auto y = static_cast<std::size_t>(r * layer.step + h.dy[k]);
      p[k] = table.base + columns[k] + y * table.width;
    }
    float* out = &layer.det[static_cast<std::size_t>(r) * layer.cols + layer.first_col];
#if defined(PLACEDB_LAYER_ROWS_AVX2)
    if (avx2) {
      determinantsAvx2(p, 0, count, h, out);
      continue;
    }
#endif
    for (int i = 0; i < count; ++i) out[i] = determinantAt(p, i, h);
  }
}

// True for edge-like maxima: box filters are not fully rotation invariant, so oblique edges can
// reach a positive determinant, but their Hessian stays strongly anisotropic (as in SIFT's edge
// test: trace^2 / det exceeds (ratio + 1)^2 / ratio for a principal curvature ratio over `ratio`).
bool isEdgeLike(const IntegralImage& integral, const ResponseLayer& layer, int r, int c, float det,
                float ratio) {
  const HessianBoxes h(layer.filter_size);
  const std::uint32_t* p[32];
  for (int k = 0; k < 32; ++k) {
    const auto y = static_cast<std::size_t>(r * layer.step + h.dy[k]);
    p[k] = integral.data() + y * integral.stride() + c * layer.step + h.dx[k];
  }
  float dxx, dyy, dxy;
  h.responses(p, 0, dxx, dyy, dxy);
  const float trace = dxx + dyy;
  return trace * trace * ratio >= (ratio + 1) * (ratio + 1) * det;
}

// Solves the 3x3 symmetric system a * x = b by Cramer's rule; false when singular.
bool solve3(const double a[3][3], const double b[3], double x[3]) {
  const double det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
                     a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                     a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
  if (!(std::abs(det) > 1e-12)) return false;
  for (int k = 0; k < 3; ++k) {
    double m[3][3];
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) m[i][j] = j == k ? b[i] : a[i][j];
    }
    x[k] = (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
            m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
            m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])) /
           det;
  }
  return true;
}

bool isStrictMaximum(const ResponseLayer& below, const ResponseLayer& middle,
                     const ResponseLayer& above, int r, int c, float value) {
  for (int dr = -1; dr <= 1; ++dr) {
    for (int dc = -1; dc <= 1; ++dc) {
      if (below.at(r + dr, c + dc) >= value || above.at(r + dr, c + dc) >= value) return false;
      if ((dr != 0 || dc != 0) && middle.at(r + dr, c + dc) >= value) return false;
    }
  }
  return true;
}

// Fits a quadratic to the 3x3x3 neighbourhood; false when the fit is degenerate or its peak lies
// nearer another sample.
bool interpolateExtremum(const ResponseLayer& below, const ResponseLayer& middle,
                         const ResponseLayer& above, int r, int c, int octave,
                         cv::KeyPoint& keypoint) {
  const double v = middle.at(r, c);
  const double gradient[3] = {(middle.at(r, c + 1) - middle.at(r, c - 1)) / 2.0,
                              (middle.at(r + 1, c) - middle.at(r - 1, c)) / 2.0,
                              (above.at(r, c) - below.at(r, c)) / 2.0};
  const double dxx = middle.at(r, c + 1) - 2 * v + middle.at(r, c - 1);
  const double dyy = middle.at(r + 1, c) - 2 * v + middle.at(r - 1, c);
  const double dss = above.at(r, c) - 2 * v + below.at(r, c);
  const double dxy = (middle.at(r + 1, c + 1) - middle.at(r + 1, c - 1) - middle.at(r - 1, c + 1) +
                      middle.at(r - 1, c - 1)) /
                     4.0;
  const double dxs =
      (above.at(r, c + 1) - above.at(r, c - 1) - below.at(r, c + 1) + below.at(r, c - 1)) / 4.0;
  const double dys =
      (above.at(r + 1, c) - above.at(r - 1, c) - below.at(r + 1, c) + below.at(r - 1, c)) / 4.0;
  const double hessian[3][3] = {{dxx, dxy, dxs}, {dxy, dyy, dys}, {dxs, dys, dss}};
  const double rhs[3] = {-gradient[0], -gradient[1], -gradient[2]};
  double offset[3];
  if (!solve3(hessian, rhs, offset)) return false;
  for (double o : offset) {
    if (!(std::abs(o) <= kMaxInterpolationOffset)) return false;
  }
  const double step = middle.step;
  keypoint.pt.x = static_cast<float>((c + offset[0]) * step);
  keypoint.pt.y = static_cast<float>((r + offset[1]) * step);
  keypoint.size =
      static_cast<float>(middle.filter_size + offset[2] * (above.filter_size - middle.filter_size));
  keypoint.response = static_cast<float>(
      v + 0.5 * (gradient[0] * offset[0] + gradient[1] * offset[1] + gradient[2] * offset[2]));
  keypoint.angle = -1;
  keypoint.octave = octave;
  return true;
}

// Keeps the sample at (r, c) of `middle`, above the threshold and a strict maximum of its 3x3x3
// neighbourhood, when it is a keypoint: not edge-like, and with an interpolated peak near it.
void offerSample(const IntegralImage& integral, const ResponseLayer& below,
                 const ResponseLayer& middle, const ResponseLayer& above, int octave,
                 float edge_ratio, int r, int c, std::vector<cv::KeyPoint>& found) {
  const float value = middle.at(r, c);
  if (edge_ratio > 0 && isEdgeLike(integral, middle, r, c, value, edge_ratio)) return;
  cv::KeyPoint keypoint;
  if (interpolateExtremum(below, middle, above, r, c, octave, keypoint)) found.push_back(keypoint);
}

#if defined(__SSE2__)
// The samples of row r in [c, c + 4) that are above the threshold and that no neighbour reaches
// (the scalar test's "neighbour >= value" rejects, so NaN neighbours would not), as bits.
int strictMaximaOfFour(const ResponseLayer& below, const ResponseLayer& middle,
                       const ResponseLayer& above, int r, int c, __m128 threshold) {
  const std::size_t at = static_cast<std::size_t>(r) * middle.cols + c;
  const __m128 value = _mm_loadu_ps(&middle.det[at]);
  const __m128 over = _mm_cmpgt_ps(value, threshold);
  if (_mm_movemask_ps(over) == 0) return 0;
  __m128 reached = _mm_setzero_ps();
  for (int dr = -1; dr <= 1; ++dr) {
    const std::size_t row = at + static_cast<std::ptrdiff_t>(dr) * middle.cols;
    for (int dc = -1; dc <= 1; ++dc) {
      const std::size_t i = row + dc;
      reached = _mm_or_ps(reached, _mm_cmpge_ps(_mm_loadu_ps(&below.det[i]), value));
      reached = _mm_or_ps(reached, _mm_cmpge_ps(_mm_loadu_ps(&above.det[i]), value));
      if (dr != 0 || dc != 0) {
        reached = _mm_or_ps(reached, _mm_cmpge_ps(_mm_loadu_ps(&middle.det[i]), value));
      }
    }
  }
  return _mm_movemask_ps(_mm_andnot_ps(reached, over));
}
#endif

void findExtremaRows(const IntegralImage& integral, const ResponseLayer& below,
                     const ResponseLayer& middle, const ResponseLayer& above, int octave,
                     const SurfDetectorSettings& settings, int row_begin, int row_end,
                     std::vector<cv::KeyPoint>& found) {
  const auto threshold = static_cast<float>(settings.hessian_threshold);
  const auto edge_ratio = static_cast<float>(settings.edge_ratio);
  // Every neighbour must be a valid sample of the largest filter (the layer above). The three
  // layers of an octave share one grid, so one index serves all three.
  const int r0 = std::max(row_begin, above.first_row + 1);
  const int r1 = std::min(row_end - 1, above.last_row - 1);
  const int c0 = above.first_col + 1;
  const int c1 = above.last_col - 1;
  for (int r = r0; r <= r1; ++r) {
    int c = c0;
#if defined(__SSE2__)
    // Four samples at a time: most fall under the threshold or below a neighbour, and those
    // that pass go on to the same tests, in the same order, as the rest of the row.
    const __m128 threshold4 = _mm_set1_ps(threshold);
    for (; c + 4 <= c1 + 1; c += 4) {
      for (int bits = strictMaximaOfFour(below, middle, above, r, c, threshold4); bits != 0;
           bits &= bits - 1) {
        offerSample(integral, below, middle, above, octave, edge_ratio, r,
                    c + __builtin_ctz(static_cast<unsigned>(bits)), found);
      }
    }
#endif
    const float* row = &middle.det[static_cast<std::size_t>(r) * middle.cols];
    for (; c <= c1; ++c) {
      if (!(row[c] > threshold) || !isStrictMaximum(below, middle, above, r, c, row[c])) continue;
      offerSample(integral, below, middle, above, octave, edge_ratio, r, c, found);
    }
  }
}

}  // namespace

int surfFilterSize(int octave, int layer) { return 3 * ((2 << octave) * (layer + 1) + 1); }

std::vector<cv::KeyPoint> detectSurfBlobs(const IntegralImage& integral,
                                          const SurfDetectorSettings& settings) {
  const int layers_per_octave = settings.intervals + 2;
  int octaves = 0;
  for (; octaves < settings.octaves; ++octaves) {
    // Octaves whose largest filter does not fit anywhere add nothing.
    const int largest = surfFilterSize(octaves, layers_per_octave - 1);
    if (largest + 2 * (1 << octaves) > std::min(integral.width(), integral.height())) break;
  }
  // The layers' buffers are kept per calling thread: fresh ones of an image's size (184 KB a
  // layer at 240x192) come from mmap, and every frame paid their page faults again. A reference,
  // so that the tasks below, on other threads, see this thread's layers.
  thread_local std::vector<ResponseLayer> kept_layers;
  std::vector<ResponseLayer>& layers = kept_layers;
  const int layer_count = octaves * layers_per_octave;
  if (static_cast<int>(layers.size()) < layer_count) layers.resize(layer_count);
  thread_local std::vector<std::vector<std::uint32_t>> kept_planes;
  std::vector<std::vector<std::uint32_t>>& planes = kept_planes;
  if (static_cast<int>(planes.size()) < octaves) planes.resize(octaves);
  std::vector<SteppedTable> tables;
  for (int octave = 0; octave < octaves; ++octave) {
    tables.push_back(steppedTable(integral, 1 << octave, planes[octave]));
  }
  for (int i = 0; i < layer_count; ++i) {
    makeLayer(integral, i / layers_per_octave, i % layers_per_octave, layers[i]);
  }

  // Responses: one task per block of rows of one layer.
  struct RowBlock {
    int item, row_begin, row_end;
  };
  std::vector<RowBlock> response_tasks;
  for (int i = 0; i < layer_count; ++i) {
    for (int r = 0; r < layers[i].rows; r += kRowsPerTask) {
      response_tasks.push_back({i, r, std::min(r + kRowsPerTask, layers[i].rows)});
    }
  }
  parallelFor(static_cast<int>(response_tasks.size()), settings.threads, [&](int t) {
    const RowBlock& task = response_tasks[t];
    computeLayerRows(tables[task.item / layers_per_octave], layers[task.item], task.row_begin,
                     task.row_end);
  });

  // Extrema: one task per block of rows of one middle layer, concatenated in task order.
  std::vector<RowBlock> extrema_tasks;
  for (int octave = 0; octave < octaves; ++octave) {
    for (int layer = 1; layer <= settings.intervals; ++layer) {
      const int index = octave * layers_per_octave + layer;
      for (int r = 0; r < layers[index].rows; r += kRowsPerTask) {
        extrema_tasks.push_back({index, r, std::min(r + kRowsPerTask, layers[index].rows)});
      }
    }
  }
  std::vector<std::vector<cv::KeyPoint>> found(extrema_tasks.size());
  parallelFor(static_cast<int>(extrema_tasks.size()), settings.threads, [&](int t) {
    const RowBlock& task = extrema_tasks[t];
    findExtremaRows(integral, layers[task.item - 1], layers[task.item], layers[task.item + 1],
                    task.item / layers_per_octave, settings, task.row_begin, task.row_end,
                    found[t]);
  });

  std::vector<cv::KeyPoint> keypoints;
  for (auto& block : found) keypoints.insert(keypoints.end(), block.begin(), block.end());
  return keypoints;
}

}  // namespace placedb
