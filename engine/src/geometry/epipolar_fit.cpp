#include "geometry/epipolar_fit.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <random>

namespace placedb {
namespace {

constexpr int kSample = 7;              // pairs that fix a fundamental matrix (up to 3 roots)
constexpr double kMinDistancePx = 0.1;  // keypoints are not located better than this

using Mat3 = std::array<double, 9>;  // row-major

// Hartley's normalisation: centroid at the origin, mean distance sqrt(2). The 7-point system
// is badly conditioned in pixel units.
struct Normalised {
  std::vector<double> x, y;
  double shift_x = 0, shift_y = 0, scale = 1;  // normalised = (p - shift) * scale
};

Normalised normalise(const std::vector<cv::Point2f>& p) {
  Normalised out;
  const double n = static_cast<double>(p.size());
  for (const auto& q : p) {
    out.shift_x += q.x / n;
    out.shift_y += q.y / n;
  }
  double mean = 0;
  for (const auto& q : p) mean += std::hypot(q.x - out.shift_x, q.y - out.shift_y) / n;
  out.scale = mean > 0 ? std::sqrt(2.0) / mean : 1.0;
  out.x.reserve(p.size());
  out.y.reserve(p.size());
  for (const auto& q : p) {
    out.x.push_back((q.x - out.shift_x) * out.scale);
    out.y.push_back((q.y - out.shift_y) * out.scale);
  }
  return out;
}

double det3(const Mat3& m) {
  return m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
         m[2] * (m[3] * m[7] - m[4] * m[6]);
}

// The 7x9 system of a sample, reduced by Gauss-Jordan elimination with partial pivoting.
struct System {
  double m[kSample][9];
  int pivot_col[kSample];
  bool is_pivot[9] = {};
  int rank = 0;
};

void buildSystem(const Normalised& a, const Normalised& b, const int* idx, System* s) {
  for (int r = 0; r < kSample; ++r) {
    const double xa = a.x[idx[r]], ya = a.y[idx[r]], xb = b.x[idx[r]], yb = b.y[idx[r]];
    const double row[9] = {xb * xa, xb * ya, xb, yb * xa, yb * ya, yb, xa, ya, 1.0};
    std::copy(row, row + 9, s->m[r]);
  }
}

void eliminateColumn(System& s, int c) {
  double(&m)[kSample][9] = s.m;
  const int rank = s.rank;
  // The first largest magnitude, by selects rather than branches that the data decide.
  int best = rank;
  double best_abs = std::abs(m[rank][c]);
  for (int r = rank + 1; r < kSample; ++r) {
    const double v = std::abs(m[r][c]);
    const bool larger = v > best_abs;
    best = larger ? r : best;
    best_abs = larger ? v : best_abs;
  }
  if (best_abs < 1e-10) return;
  if (best != rank)
    for (int cc = 0; cc < 9; ++cc) std::swap(m[best][cc], m[rank][cc]);
  const double inv = 1.0 / m[rank][c];
  double pivot_row[9];  // the rows below read it from registers, not back from m
  for (int cc = 0; cc < 9; ++cc) pivot_row[cc] = m[rank][cc] * inv;
  std::copy(pivot_row, pivot_row + 9, m[rank]);
  for (int r = 0; r < kSample; ++r) {
    if (r == rank || m[r][c] == 0.0) continue;
    const double f = m[r][c];
    for (int cc = 0; cc < 9; ++cc) m[r][cc] -= f * pivot_row[cc];
  }
  s.pivot_col[rank] = c;
  s.is_pivot[c] = true;
  ++s.rank;
}

// Several systems column by column, each as on its own: the elimination is a chain of
// dependent steps (a division among them), and independent chains side by side keep the
// processor busy while one waits.
void eliminate(System* systems, int count) {
  for (int c = 0; c < 9; ++c)
    for (int k = 0; k < count; ++k)
      if (systems[k].rank < kSample) eliminateColumn(systems[k], c);
}

// The fundamental matrices (normalised coordinates) through the 7 pairs of an eliminated
// system: its 2-dimensional null space, then det(F) = 0, a cubic in the pencil.
int sevenPoint(const System& system, Mat3* out) {
  const double(&m)[kSample][9] = system.m;
  const int* pivot_col = system.pivot_col;
  const bool* is_pivot = system.is_pivot;
  const int rank = system.rank;
  if (rank != kSample) return 0;  // degenerate sample (repeated or collinear points)
  int free_cols[2], nfree = 0;
  for (int c = 0; c < 9; ++c)
    if (!is_pivot[c]) free_cols[nfree++] = c;
  Mat3 f1{}, f2{};
  Mat3* basis[2] = {&f1, &f2};
  for (int k = 0; k < 2; ++k) {
    Mat3& v = *basis[k];
    v[free_cols[k]] = 1.0;
    for (int r = 0; r < kSample; ++r) v[pivot_col[r]] = -m[r][free_cols[k]];
  }
  // det(f2 + t (f1 - f2)) = c3 t^3 + c2 t^2 + c1 t + c0, from its values at t = 0, 1, -1, 2.
  auto detAt = [&](double t) {
    Mat3 f;
    for (int i = 0; i < 9; ++i) f[i] = f2[i] + t * (f1[i] - f2[i]);
    return det3(f);
  };
  const double d0 = detAt(0), d1 = detAt(1), dm1 = detAt(-1), d2 = detAt(2);
  const double c0 = d0, c2 = (d1 + dm1) / 2 - d0, s = (d1 - dm1) / 2;
  const double c3 = (d2 - 4 * c2 - d0 - 2 * s) / 6, c1 = s - c3;
  // Fixed-size arrays: the same solver on the same numbers, without two allocations a sample.
  const cv::Matx<double, 1, 4> coefficients(c3, c2, c1, c0);
  cv::Matx<double, 3, 1> roots;
  const int count = cv::solveCubic(coefficients, roots);
  int models = 0;
  for (int i = 0; i < count && i < 3; ++i) {
    Mat3& f = out[models++];
    for (int j = 0; j < 9; ++j) f[j] = f2[j] + roots(i) * (f1[j] - f2[j]);
  }
  return models;
}

// Back to pixels: F = Tb' Fn Ta, with T(p) = (p - shift) * scale.
Mat3 toPixels(const Mat3& fn, const Normalised& a, const Normalised& b) {
  const double ta[9] = {a.scale, 0, -a.scale * a.shift_x, 0, a.scale, -a.scale * a.shift_y, 0,
                        0,       1};
  const double tb[9] = {b.scale, 0, -b.scale * b.shift_x, 0, b.scale, -b.scale * b.shift_y, 0,
                        0,       1};
  double tmp[9];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      double s = 0;
      for (int k = 0; k < 3; ++k) s += fn[r * 3 + k] * ta[k * 3 + c];
      tmp[r * 3 + c] = s;
    }
  Mat3 f;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      double s = 0;
      for (int k = 0; k < 3; ++k) s += tb[k * 3 + r] * tmp[k * 3 + c];  // Tb transposed
      f[r * 3 + c] = s;
    }
  return f;
}

// A distance from its two parts (below): the numerator and the smaller squared line norm.
double distanceFromParts(double num, double norm) {
  return norm > 0 ? num / std::sqrt(norm) : 1e30;
}

// The larger of the two point-to-epipolar-line distances, pixels.
double distance(const Mat3& f, const cv::Point2f& a, const cv::Point2f& b) {
  const double lb0 = f[0] * a.x + f[1] * a.y + f[2], lb1 = f[3] * a.x + f[4] * a.y + f[5],
               lb2 = f[6] * a.x + f[7] * a.y + f[8];
  const double la0 = f[0] * b.x + f[3] * b.y + f[6], la1 = f[1] * b.x + f[4] * b.y + f[7];
  const double num = std::abs(b.x * lb0 + b.y * lb1 + lb2);
  const double nb = lb0 * lb0 + lb1 * lb1, na = la0 * la0 + la1 * la1;
  return distanceFromParts(num, std::min(nb, na));
}

// The pairs in double, one array per coordinate, and per model the two parts of distance():
// a loop without branches over plain arrays, which the compiler runs two pairs at a time with
// the same operations per pair as distance().
struct Coordinates {
  std::vector<double> ax, ay, bx, by;
  Coordinates(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b, int n) {
    for (int i = 0; i < n; ++i) {
      ax.push_back(a[i].x);
      ay.push_back(a[i].y);
      bx.push_back(b[i].x);
      by.push_back(b[i].y);
    }
  }
};

void distanceParts(const Mat3& f, const Coordinates& p, double* num, double* norm) {
  const int n = static_cast<int>(p.ax.size());
  const double* ax = p.ax.data();
  const double* ay = p.ay.data();
  const double* bx = p.bx.data();
  const double* by = p.by.data();
  for (int i = 0; i < n; ++i) {
    const double lb0 = f[0] * ax[i] + f[1] * ay[i] + f[2], lb1 = f[3] * ax[i] + f[4] * ay[i] + f[5],
                 lb2 = f[6] * ax[i] + f[7] * ay[i] + f[8];
    const double la0 = f[0] * bx[i] + f[3] * by[i] + f[6], la1 = f[1] * bx[i] + f[4] * by[i] + f[7];
    num[i] = std::abs(bx[i] * lb0 + by[i] * lb1 + lb2);
    const double nb = lb0 * lb0 + lb1 * lb1, na = la0 * la0 + la1 * la1;
    norm[i] = std::min(nb, na);
  }
}

// Whether a pair is clearly beyond max_error, from distance()'s parts: the square root and
// the division are left for the others. `far_sq` is max_error^2 (1 + 1e-6): well beyond the
// rounding of either side, so a pair it rules out is one that distance() would have put beyond
// max_error too. Computed without branches: which pairs are near is up to the data.
bool farFor(double num, double norm, double far_sq) {
  // Away from underflow and overflow of the squares, whose rounding the margin would not cover.
  return (norm > 1e-200) & (num < 1e100) & (num * num > far_sq * norm);
}

double log10Choose(int n, int k) {
  return (std::lgamma(n + 1.0) - std::lgamma(k + 1.0) - std::lgamma(n - k + 1.0)) / std::log(10.0);
}

double log10AlphaPerPx(cv::Size2f size) {
  const double w = std::max(1.f, size.width), h = std::max(1.f, size.height);
  return std::log10(2.0 * std::hypot(w, h) / (w * h));
}

}  // namespace

double epipolarLog10Nfa(int n, int k, double eps_px, cv::Size2f candidate_size, int iterations) {
  if (n <= kSample || k <= kSample || k > n) return 1e9;
  const double log_alpha =
      std::min(0.0, log10AlphaPerPx(candidate_size) + std::log10(std::max(eps_px, kMinDistancePx)));
  return std::log10(3.0 * std::max(1, iterations) * (n - kSample)) +
         log10Choose(n - kSample, k - kSample) + (k - kSample) * log_alpha;
}

EpipolarFit fitEpipolar(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b,
                        cv::Size2f candidate_size, const EpipolarFitSettings& settings) {
  EpipolarFit fit;
  const int n = static_cast<int>(std::min(a.size(), b.size()));
  if (n <= kSample || settings.iterations <= 0) return fit;
  const Normalised na = normalise(a), nb = normalise(b);
  const Coordinates coordinates(a, b, n);
  std::vector<double> num(static_cast<std::size_t>(n)), norm(static_cast<std::size_t>(n));
  std::vector<int> near(static_cast<std::size_t>(n));

  // Everything but the distance of the NFA, per k, once.
  const int iterations = settings.iterations;
  const double log_tests = std::log10(3.0 * iterations * (n - kSample));
  const double log_alpha_px = log10AlphaPerPx(candidate_size);
  std::vector<double> log_choose(static_cast<std::size_t>(n - kSample + 1));
  for (int j = 0; j <= n - kSample; ++j) log_choose[j] = log10Choose(n - kSample, j);
  const double pass_at = std::log10(settings.max_nfa);
  const double count_pass_at =
      settings.stop_at_inliers_nfa > 0 ? std::log10(settings.stop_at_inliers_nfa) : 1e300;
  // Whether `draws` samples find one of 7 agreeing pairs with the confidence asked for.
  const double log_miss = settings.confidence > 0 ? std::log1p(-settings.confidence) : 0.0;
  auto confident = [&](int draws) {
    if (settings.confidence <= 0 || fit.most_within_max_error <= kSample) return false;
    const double all_agree = std::pow(double(fit.most_within_max_error) / n, kSample);
    return all_agree >= 1.0 || draws * std::log1p(-all_agree) <= log_miss;
  };
  const double far_sq = settings.max_error_px * settings.max_error_px * (1 + 1e-6);

  std::mt19937 rng(0x5eedu + static_cast<unsigned>(n));
  std::vector<double> close;
  close.reserve(static_cast<std::size_t>(n));
  Mat3 best_f{};
  // Sets of pairs tried, as bit masks (n <= 64; a mask is never 0), in an open-addressing
  // table at most a quarter full: no allocation per draw.
  std::size_t slots = 16;
  while (slots < 4 * static_cast<std::size_t>(iterations)) slots *= 2;
  std::vector<std::uint64_t> drawn(n <= 64 ? slots : 0);
  auto firstDraw = [&](std::uint64_t set) {
    std::size_t at = static_cast<std::size_t>((set * 0x9e3779b97f4a7c15u) >> 32) & (slots - 1);
    for (; drawn[at] != 0; at = (at + 1) & (slots - 1))
      if (drawn[at] == set) return false;
    drawn[at] = set;
    return true;
  };
  // One model: its distances, most_within_max_error and the NFA over k.
  auto evaluate = [&](const Mat3& f) {
    close.clear();
    distanceParts(f, coordinates, num.data(), norm.data());
    // The pairs not ruled out, listed without a branch per pair; then distance()'s own value
    // for each of them.
    int near_count = 0;
    for (int i = 0; i < n; ++i) {
      near[near_count] = i;
      near_count += !farFor(num[i], norm[i], far_sq);
    }
    for (int j = 0; j < near_count; ++j) {
      const int i = near[j];
      const double d = distanceFromParts(num[i], norm[i]);
      if (d <= settings.max_error_px) close.push_back(d);
    }
    fit.most_within_max_error = std::max(fit.most_within_max_error, static_cast<int>(close.size()));
    if (static_cast<int>(close.size()) <= kSample) return;
    std::sort(close.begin(), close.end());
    for (int k = kSample + 1; k <= static_cast<int>(close.size()); ++k) {
      const double eps = std::max(close[k - 1], kMinDistancePx);
      const double log_alpha = std::min(0.0, log_alpha_px + std::log10(eps));
      const double log_nfa = log_tests + log_choose[k - kSample] + (k - kSample) * log_alpha;
      if (log_nfa < fit.log10_nfa) {
        fit.log10_nfa = log_nfa;
        fit.inliers = k;
        fit.threshold_px = close[k - 1];
        best_f = f;
      }
    }
  };
  // Iterations go in pairs whose eliminations run side by side. The second one's draw comes
  // before the first one's models are scored, which changes nothing: the scores do not steer
  // the draws, and a stop after the first leaves the second unused.
  constexpr int kBatch = 2;
  bool stopped = false;
  for (int it = 0; it < iterations && !stopped; it += kBatch) {
    const int batch = std::min(kBatch, iterations - it);
    System systems[kBatch];
    int fresh = 0;
    bool repeat[kBatch] = {};
    for (int j = 0; j < batch; ++j) {
      // Early samples come from the first pairs only (the most reliable), widening to all of
      // them by half the iterations.
      const int pool =
          std::min(n, kSample + std::max(1, (n - kSample) * 2 * (it + j + 1) / iterations));
      int idx[kSample];
      for (int s = 0; s < kSample;) {
        // mt19937's values fit 32 bits: the same remainder by a cheaper division.
        const int c =
            static_cast<int>(static_cast<std::uint32_t>(rng()) % static_cast<std::uint32_t>(pool));
        if (std::find(idx, idx + s, c) == idx + s) idx[s++] = c;
      }
      // A set of pairs drawn again fits the same models: on few pairs most draws are repeats
      // (8 pairs hold 8 sets of 7, 10 hold 120, against 400 draws). The random stream and the
      // stops go on as before, so the fit is the one every draw would give.
      if (n <= 64) {
        std::uint64_t set = 0;
        for (int s = 0; s < kSample; ++s) set |= std::uint64_t{1} << idx[s];
        repeat[j] = !firstDraw(set);
      }
      if (!repeat[j]) buildSystem(na, nb, idx, &systems[fresh++]);
    }
    eliminate(systems, fresh);
    for (int j = 0, k = 0; j < batch; ++j) {
      fit.draws = it + j + 1;
      if (repeat[j]) continue;
      Mat3 models[3];
      const int count = sevenPoint(systems[k++], models);
      for (int m = 0; m < count; ++m) evaluate(toPixels(models[m], na, nb));
      if ((settings.stop_when_passed && fit.log10_nfa <= pass_at) ||
          (settings.stop_at_inliers > 0 && fit.most_within_max_error >= settings.stop_at_inliers &&
           fit.log10_nfa <= count_pass_at) ||
          confident(it + j + 1)) {
        stopped = true;
        break;
      }
    }
  }
  fit.passed = fit.log10_nfa <= pass_at;
  if (fit.inliers == 0) return fit;
  fit.fundamental = cv::Matx33d(best_f.data());
  for (int i = 0; i < n; ++i) {
    const double d = distance(best_f, a[i], b[i]);
    if (d <= fit.threshold_px) fit.inlier_pairs.push_back(i);
    if (d <= settings.max_error_px) fit.agreeing_pairs.push_back(i);
  }
  return fit;
}

}  // namespace placedb
