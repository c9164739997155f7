#include "plots.h"

#include <fmt/format.h>
#include <plplot/plplot.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "placedb/error.h"

namespace placedb::cli {
namespace fs = std::filesystem;
namespace {

// Colour map 0 slots, redefined after plinit for a white page.
enum Colour { kInk = 1, kBlue = 2, kRed = 3, kGreen = 4, kGrey = 5 };

// PLplot ends the process on a fatal error; this at least makes it one placedb error line with
// the documented I/O exit status.
int onPlplotExit(PLCHAR_VECTOR message) {
  std::fprintf(stderr, "placedb: error: plotting failed: %s\n", message ? message : "");
  return static_cast<int>(ErrorCode::kIo);
}

struct Range {
  double lo, hi;
};

Range rangeOf(const std::vector<double>& values, bool from_zero) {
  Range r{from_zero ? 0.0 : INFINITY, -INFINITY};
  for (double v : values)
    if (std::isfinite(v)) {
      r.lo = std::min(r.lo, v);
      r.hi = std::max(r.hi, v);
    }
  if (!std::isfinite(r.lo) || !std::isfinite(r.hi)) return {0, 1};
  if (r.hi <= r.lo) r.hi = r.lo + 1;
  double pad = 0.04 * (r.hi - r.lo);
  return {from_zero && r.lo >= 0 ? r.lo : r.lo - pad, r.hi + pad};
}

class Figure {
 public:
  Figure(const fs::path& file, Range x, Range y, const std::string& xlabel,
         const std::string& ylabel, const std::string& title) {
    plsexit(onPlplotExit);
    plsdev("pngcairo");
    plsfnam(file.string().c_str());
    plsetopt("geometry", "960x540");
    plscolbg(255, 255, 255);
    plinit();
    plscol0(kInk, 0, 0, 0);
    plscol0(kBlue, 31, 119, 180);
    plscol0(kRed, 214, 39, 40);
    plscol0(kGreen, 44, 160, 44);
    plscol0(kGrey, 170, 170, 170);
    plcol0(kInk);
    plenv(x.lo, x.hi, y.lo, y.hi, 0, 2);  // 2: axes with a grid
    pllab(xlabel.c_str(), ylabel.c_str(), title.c_str());
  }
  ~Figure() { plend(); }
  Figure(const Figure&) = delete;
  Figure& operator=(const Figure&) = delete;

  // A non-finite value (a bad frame, which has no such figure) leaves a gap in the line rather
  // than a drop to zero; a finite value between two gaps is drawn as a dot.
  void line(const std::vector<double>& x, const std::vector<double>& y, Colour colour) {
    const std::size_t n = std::min(x.size(), y.size());
    plcol0(colour);
    plwidth(1.5);
    for (std::size_t start = 0; start < n;) {
      while (start < n && !std::isfinite(y[start])) ++start;
      std::size_t end = start;
      while (end < n && std::isfinite(y[end])) ++end;
      const auto count = static_cast<PLINT>(end - start);
      if (count >= 2) plline(count, x.data() + start, y.data() + start);
      if (count == 1) plpoin(1, x.data() + start, y.data() + start, 1);
      start = end;
    }
  }
  void points(const std::vector<double>& x, const std::vector<double>& y, Colour colour,
              int glyph) {
    std::size_t n = std::min(x.size(), y.size());
    if (n == 0) return;
    plcol0(colour);
    plpoin(static_cast<PLINT>(n), x.data(), y.data(), glyph);
  }
  void rug(const std::vector<double>& x, double y0, double y1, Colour colour) {
    plcol0(colour);
    plwidth(2.0);
    for (double v : x) pljoin(v, y0, v, y1);
  }
  void legend(const std::vector<std::pair<Colour, std::string>>& entries) {
    // A hand-placed text legend: PLplot's pllegend needs many parallel arrays for little gain.
    for (std::size_t i = 0; i < entries.size(); ++i) {
      plcol0(entries[i].first);
      plmtex("t", -1.5 - 1.3 * static_cast<double>(i), 0.02, 0.0, entries[i].second.c_str());
    }
    plcol0(kInk);
  }
};

bool seriesPlot(const fs::path& folder, const std::string& file, const std::vector<double>& x,
                const std::vector<double>& y, const std::string& ylabel, const std::string& title) {
  if (y.empty() || x.size() != y.size()) return false;
  Figure figure(folder / file, rangeOf(x, false), rangeOf(y, true), "frame", ylabel, title);
  figure.line(x, y, kBlue);
  return true;
}

}  // namespace

bool pngPlottingAvailable() {
  const char** menus = nullptr;
  const char** names = nullptr;
  int count = 64;
  std::vector<const char*> menu(static_cast<std::size_t>(count)), name(menu.size());
  menus = menu.data();
  names = name.data();
  plgDevs(&menus, &names, &count);
  for (int i = 0; i < count; ++i)
    if (names[i] && std::strcmp(names[i], "pngcairo") == 0) return true;
  return false;
}

std::vector<WrittenPlot> writePlots(const RunSeries& s, const std::vector<PrPoint>& pr_curve,
                                    const fs::path& folder) {
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec || !fs::is_directory(folder))
    throw Error(ErrorCode::kIo, fmt::format("cannot create plot folder {}", folder.string()));
  if (!pngPlottingAvailable())
    throw Error(
        ErrorCode::kIo,
        "PLplot has no pngcairo driver: install plplot-driver-cairo (scripts/install-deps.sh)");

  std::vector<WrittenPlot> written;
  if (!pr_curve.empty()) {
    std::vector<double> recall, precision;
    for (const auto& p : pr_curve) {
      recall.push_back(100 * p.recall);
      precision.push_back(100 * p.precision);
    }
    Figure figure(folder / "precision_recall.png", {0, 100}, {0, 102}, "recall (%)",
                  "precision (%)", "Precision-recall over score thresholds");
    figure.line(recall, precision, kBlue);
    figure.points(recall, precision, kBlue, 17);
    written.push_back({"precision_recall.png",
                       "precision against recall as the score threshold sweeps from the highest "
                       "score down; the curve's recall at 100% precision is the R@100P figure"});
  }

  if (!s.score.empty() && s.score.size() == s.frame.size()) {
    Range y = rangeOf(s.score, true);
    y.hi = std::max(y.hi, 1.0) * 1.15;  // headroom for the legend
    Figure figure(folder / "score.png", rangeOf(s.frame, false), y, "frame", "loop-closure score",
                  "Best hypothesis' score per frame");
    // Ground-truth loop frames as a grey rug along the bottom, accepted closures as red circles.
    figure.rug(s.gt_loop_frames, y.lo, y.lo + 0.05 * (y.hi - y.lo), kGrey);
    figure.line(s.frame, s.score, kBlue);
    std::vector<double> accepted_scores;
    for (double f : s.accepted_frames) {
      auto it = std::lower_bound(s.frame.begin(), s.frame.end(), f);
      std::size_t i = static_cast<std::size_t>(it - s.frame.begin());
      accepted_scores.push_back(i < s.score.size() ? s.score[i] : 0.0);
    }
    figure.points(s.accepted_frames, accepted_scores, kRed, 4);
    figure.legend({{kBlue, "score"}, {kRed, "accepted closure"}, {kGrey, "ground-truth loop"}});
    written.push_back({"score.png",
                       "the filter's best loop-closure hypothesis per frame (its score, 0..1); "
                       "grey ticks mark frames that truly revisit a place, red dots the closures "
                       "the engine accepted"});
  }
  if (seriesPlot(folder, "vocabulary.png", s.frame, s.vocabulary_size, "words",
                 "Vocabulary size per frame"))
    written.push_back({"vocabulary.png",
                       "visual words in the index: grows with new places, flattens when "
                       "places repeat or memory management moves locations to long-term memory"});
  if (seriesPlot(folder, "quantisation_error.png", s.frame, s.mean_quantisation_error,
                 "mean distance", "Mean quantisation error per frame"))
    written.push_back({"quantisation_error.png",
                       "mean distance of a frame's descriptors to the words they were assigned: "
                       "how well the vocabulary describes what the camera sees"});
  if (seriesPlot(folder, "wm_size.png", s.frame, s.wm_size, "locations",
                 "Working-memory size per frame"))
    written.push_back({"wm_size.png",
                       "locations in working memory, the ones the filter compares against; "
                       "bounded when a time or size limit is set"});
  if (seriesPlot(folder, "time.png", s.frame, s.time_ms, "ms", "Time per frame"))
    written.push_back({"time.png", "wall time per frame, feature extraction included"});
  return written;
}

}  // namespace placedb::cli
