#include "report/plots.h"

#include <fmt/format.h>
#include <plplot/plplot.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iterator>

#include "placedb/error.h"
#include "whole_file.h"

namespace placedb::cli {
namespace fs = std::filesystem;
namespace {

// Colour map 0 slots, redefined after plinit for a white page.
enum Colour {
  kInk = 1,
  kBlue = 2,
  kRed = 3,
  kGreen = 4,
  kGrey = 5,
  kOrange = 6,
  kPurple = 7,
  kBrown = 8,
  kPink = 9,
  kOlive = 10,
  kCyan = 11,
  kVeil = 12  // translucent white behind a legend
};

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
  // The destructor puts the PNG on `out`. PLplot closes the stream it draws on, so it draws on
  // one in memory of its own.
  Figure(std::FILE* out, Range x, Range y, const std::string& xlabel, const std::string& ylabel,
         const std::string& title)
      : out_(out), drawn_(open_memstream(&png_, &png_size_)) {
    if (!drawn_) throw Error(ErrorCode::kInternal, "plotting: no memory for a figure");
    plsexit(onPlplotExit);
    plsdev("pngcairo");
    plsfile(drawn_);
    plsetopt("geometry", "960x540");
    plscolbg(255, 255, 255);
    plinit();
    plscol0(kInk, 0, 0, 0);
    plscol0(kBlue, 31, 119, 180);
    plscol0(kRed, 214, 39, 40);
    plscol0(kGreen, 44, 160, 44);
    plscol0(kGrey, 170, 170, 170);
    plscol0(kOrange, 255, 127, 14);
    plscol0(kPurple, 148, 103, 189);
    plscol0(kBrown, 140, 86, 75);
    plscol0(kPink, 227, 119, 194);
    plscol0(kOlive, 188, 189, 34);
    plscol0(kCyan, 23, 190, 207);
    plscol0a(kVeil, 255, 255, 255, 0.8);
    plcol0(kInk);
    plenv(x.lo, x.hi, y.lo, y.hi, 0, 2);  // 2: axes with a grid
    pllab(xlabel.c_str(), ylabel.c_str(), title.c_str());
  }
  ~Figure() {
    plend();  // writes the PNG and closes drawn_
    if (png_) std::fwrite(png_, 1, png_size_, out_);
    std::free(png_);
  }
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
  // `scale` enlarges the glyph, for a single point that must stand out of a curve.
  void points(const std::vector<double>& x, const std::vector<double>& y, Colour colour, int glyph,
              double scale = 1.0) {
    std::size_t n = std::min(x.size(), y.size());
    if (n == 0) return;
    plcol0(colour);
    plssym(0.0, scale);
    plpoin(static_cast<PLINT>(n), x.data(), y.data(), glyph);
    plssym(0.0, 1.0);
  }
  // The band between `below` and `above`, over each run of frames where both are finite.
  void band(const std::vector<double>& x, const std::vector<double>& below,
            const std::vector<double>& above, Colour colour) {
    const std::size_t n = std::min({x.size(), below.size(), above.size()});
    auto finite = [&](std::size_t i) { return std::isfinite(below[i]) && std::isfinite(above[i]); };
    plcol0(colour);
    plpsty(0);
    std::vector<double> px, py;
    for (std::size_t start = 0; start < n;) {
      while (start < n && !finite(start)) ++start;
      std::size_t end = start;
      while (end < n && finite(end)) ++end;
      px.clear();
      py.clear();
      for (std::size_t i = start; i < end; ++i) {
        px.push_back(x[i]);
        py.push_back(above[i]);
      }
      for (std::size_t i = end; i-- > start;) {
        px.push_back(x[i]);
        py.push_back(below[i]);
      }
      // A single frame is a polygon of no width: widen it to a bar of one frame.
      if (end - start == 1) {
        px = {x[start] - 0.5, x[start] + 0.5, x[start] + 0.5, x[start] - 0.5};
        py = {above[start], above[start], below[start], below[start]};
      }
      if (px.size() >= 3) plfill(static_cast<PLINT>(px.size()), px.data(), py.data());
      start = end;
    }
  }
  void rug(const std::vector<double>& x, double y0, double y1, Colour colour) {
    plcol0(colour);
    plwidth(2.0);
    for (double v : x) pljoin(v, y0, v, y1);
  }
  // A hand-placed text legend inside the top (or bottom) left corner: PLplot's pllegend needs
  // many parallel arrays for little gain. A translucent veil under it keeps the text readable
  // over grid lines and data without hiding the data.
  void legend(const std::vector<std::pair<Colour, std::string>>& entries, bool bottom = false) {
    const double n = static_cast<double>(entries.size());
    std::size_t longest = 0;
    for (const auto& entry : entries) longest = std::max(longest, entry.second.size());
    veil(static_cast<double>(longest), (bottom ? 2.0 : 2.2) + 1.3 * (n - 1), bottom);
    for (std::size_t i = 0; i < entries.size(); ++i) {
      const double row = static_cast<double>(i);
      plcol0(entries[i].first);
      if (bottom)
        plmtex("b", -1.0 - 1.3 * (n - 1 - row), 0.02, 0.0, entries[i].second.c_str());
      else
        plmtex("t", -1.5 - 1.3 * row, 0.02, 0.0, entries[i].second.c_str());
    }
    plcol0(kInk);
  }

 private:
  // A box from the left edge, `chars` characters wide and `lines` character heights tall, at the
  // top or bottom of the plot. Sizes are in millimetres on the page, turned into world units.
  void veil(double chars, double lines, bool bottom) {
    PLFLT default_height = 0, height = 0;
    plgchr(&default_height, &height);
    PLFLT page_x0 = 0, page_x1 = 0, page_y0 = 0, page_y1 = 0;
    plgspa(&page_x0, &page_x1, &page_y0, &page_y1);
    PLFLT vp_x0 = 0, vp_x1 = 0, vp_y0 = 0, vp_y1 = 0;
    plgvpd(&vp_x0, &vp_x1, &vp_y0, &vp_y1);
    PLFLT x0 = 0, x1 = 0, y0 = 0, y1 = 0;
    plgvpw(&x0, &x1, &y0, &y1);
    const double width_mm = (vp_x1 - vp_x0) * (page_x1 - page_x0);
    const double height_mm = (vp_y1 - vp_y0) * (page_y1 - page_y0);
    if (width_mm <= 0 || height_mm <= 0) return;
    // 0.7 character heights a character: a little wider than the average glyph.
    const double w = std::min(1.0, 0.02 + (0.7 * chars + 1.0) * height / width_mm);
    const double h = std::min(1.0, lines * height / height_mm);
    const double left = x0, right = x0 + w * (x1 - x0);
    const double low = bottom ? y0 : y1 - h * (y1 - y0), high = bottom ? y0 + h * (y1 - y0) : y1;
    std::vector<double> xs = {left, right, right, left}, ys = {low, low, high, high};
    plcol0(kVeil);
    plpsty(0);
    plfill(4, xs.data(), ys.data());
  }

  std::FILE* out_;
  char* png_ = nullptr;
  std::size_t png_size_ = 0;
  std::FILE* drawn_;
};

bool seriesPlot(const fs::path& folder, const std::string& file, const std::vector<double>& x,
                const std::vector<double>& y, const std::string& ylabel, const std::string& title) {
  if (y.empty() || x.size() != y.size()) return false;
  writeWholeFile(folder / file, [&](std::FILE* out) {
    Figure figure(out, rangeOf(x, false), rangeOf(y, true), "frame", ylabel, title);
    figure.line(x, y, kBlue);
  });
  return true;
}

// A percent axis fitted to the values (with room for the marks on it), padded on both sides.
Range percentRange(const std::vector<double>& values) {
  Range r = rangeOf(values, false);
  const double span = std::max(r.hi - r.lo, 2.0);
  const double mid = 0.5 * (r.lo + r.hi);
  r = {std::max(mid - 0.5 * span, 0.0), std::min(mid + 0.5 * span, 100.0)};
  const double pad = 0.06 * (r.hi - r.lo);
  return {r.lo - pad, r.hi + pad};
}

bool precisionRecallPlot(const fs::path& folder, const Evaluation& evaluation) {
  if (evaluation.pr_curve.empty()) return false;
  const EvalFigures& f = evaluation.figures;
  std::vector<double> recall, precision;
  for (const auto& p : evaluation.pr_curve) {
    recall.push_back(100 * p.recall);
    precision.push_back(100 * p.precision);
  }
  // The marks belong on the axes as well as the curve.
  std::vector<double> all_recall = recall, all_precision = precision;
  const bool has_r100 = std::isfinite(f.recall_at_100_precision);
  const bool has_operating = f.accepted_precision && f.accepted_recall;
  if (has_r100) {
    all_recall.push_back(f.recall_at_100_precision);
    all_precision.push_back(100);
  }
  if (has_operating) {
    all_recall.push_back(*f.accepted_recall);
    all_precision.push_back(*f.accepted_precision);
  }
  // The legend sits in the bottom left corner, where a precision-recall curve seldom goes.
  Range y = percentRange(all_precision);
  y.lo -= 0.15 * (y.hi - y.lo);
  writeWholeFile(folder / "precision_recall.png", [&](std::FILE* out) {
    Figure figure(out, percentRange(all_recall), y, "recall (%)", "precision (%)",
                  "Precision-recall over score thresholds");
    figure.line(recall, precision, kBlue);
    figure.points(recall, precision, kBlue, 17);
    std::vector<std::pair<Colour, std::string>> legend = {{kBlue, "curve over score thresholds"}};
    if (has_r100) {
      figure.points({f.recall_at_100_precision}, {100.0}, kGreen, 11, 2.5);
      legend.push_back({kGreen, fmt::format("R@100P (window {}): {:.2f}% recall at 100% precision",
                                            f.window, f.recall_at_100_precision)});
    }
    if (has_operating) {
      figure.points({*f.accepted_recall}, {*f.accepted_precision}, kRed, 4, 2.5);
      legend.push_back({kRed, fmt::format("accepted: precision {:.2f}%, recall {:.2f}% ({} right, "
                                          "{} wrong)",
                                          *f.accepted_precision, *f.accepted_recall,
                                          f.accepted_true, f.accepted_false)});
    } else {
      legend.push_back({kRed, "accepted: none"});
    }
    figure.legend(legend, true);
  });
  return true;
}

// The score of each frame in `frames` (which are among s.frame), for marking them on the line.
std::vector<double> scoresAt(const RunSeries& s, const std::vector<double>& frames) {
  std::vector<double> scores;
  for (double f : frames) {
    auto it = std::lower_bound(s.frame.begin(), s.frame.end(), f);
    const auto i = static_cast<std::size_t>(it - s.frame.begin());
    scores.push_back(i < s.score.size() ? s.score[i] : 0.0);
  }
  return scores;
}

bool scorePlot(const fs::path& folder, const RunSeries& s) {
  if (s.score.empty() || s.score.size() != s.frame.size()) return false;
  Range y = rangeOf(s.score, true);
  y.hi = std::max(y.hi, 1.0) * 1.45;  // headroom for the legend
  writeWholeFile(folder / "score.png", [&](std::FILE* out) {
    Figure figure(out, rangeOf(s.frame, false), y, "frame", "loop-closure score",
                  "Best hypothesis' score per frame");
    if (!s.judged) {
      figure.line(s.frame, s.score, kBlue);
      figure.points(s.accepted_wrong, scoresAt(s, s.accepted_wrong), kPurple, 4);
      figure.legend({{kBlue, "score"},
                     {kPurple, fmt::format("accepted closure, no ground truth to judge it ({})",
                                           s.accepted_wrong.size())}});
      return;
    }
    // Two bands along the bottom: every ground-truth loop frame (grey), and under it those the
    // engine missed (orange), so a gap in the orange band is a loop found.
    const double tick = 0.04 * (y.hi - y.lo);
    figure.rug(s.gt_loop_frames, y.lo + tick, y.lo + 2 * tick, kGrey);
    figure.rug(s.missed_loops, y.lo, y.lo + tick, kOrange);
    figure.line(s.frame, s.score, kBlue);
    figure.points(s.accepted_right, scoresAt(s, s.accepted_right), kGreen, 4);
    figure.points(s.accepted_wrong, scoresAt(s, s.accepted_wrong), kRed, 5, 1.6);
    figure.legend(
        {{kBlue, "score"},
         {kGreen, fmt::format("right accepted closure ({})", s.accepted_right.size())},
         {kRed, fmt::format("wrong accepted closure ({})", s.accepted_wrong.size())},
         {kGrey, fmt::format("ground-truth loop frame ({})", s.gt_loop_frames.size())},
         {kOrange, fmt::format("missed loop: no right closure ({})", s.missed_loops.size())}});
  });
  return true;
}

bool stagePlot(const fs::path& folder, const RunSeries& s) {
  std::vector<const RunSeries::Stage*> stages;
  for (const auto& stage : s.stages)
    if (stage.ms.size() == s.frame.size() && !s.frame.empty()) stages.push_back(&stage);
  if (stages.empty()) return false;
  // Running sums: the band of stage k lies between sum k-1 and sum k.
  std::vector<std::vector<double>> sums;
  std::vector<double> running(s.frame.size(), 0.0);
  for (const auto* stage : stages) {
    for (std::size_t i = 0; i < running.size(); ++i) running[i] += stage->ms[i];
    sums.push_back(running);
  }
  Range y = rangeOf(sums.back(), true);
  y.hi += 0.06 * static_cast<double>(stages.size()) * (y.hi - y.lo);  // room for the legend
  writeWholeFile(folder / "time_by_stage.png", [&](std::FILE* out) {
    Figure figure(out, rangeOf(s.frame, false), y, "frame", "ms", "Time per frame by stage");
    static const Colour kStageColours[] = {kBlue,  kOrange, kGreen, kRed, kPurple,
                                           kBrown, kPink,   kOlive, kCyan};
    const std::vector<double> zero(s.frame.size(), 0.0);
    std::vector<std::pair<Colour, std::string>> legend;
    for (std::size_t k = 0; k < stages.size(); ++k) {
      const Colour colour = kStageColours[k % std::size(kStageColours)];
      figure.band(s.frame, k == 0 ? zero : sums[k - 1], sums[k], colour);
      legend.push_back({colour, stages[k]->name});
    }
    // Top of the stack first, as the bands are piled.
    std::reverse(legend.begin(), legend.end());
    figure.legend(legend);
  });
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

std::vector<WrittenPlot> writePlots(const RunSeries& s, const Evaluation& evaluation,
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
  if (precisionRecallPlot(folder, evaluation))
    written.push_back({"precision_recall.png",
                       "precision against recall as the score threshold sweeps from the highest "
                       "score down; the green diamond is the recall at 100% precision (R@100P), "
                       "the red circle the closures the engine accepted with its own threshold"});
  if (scorePlot(folder, s))
    written.push_back(
        {"score.png", s.judged
                          ? "the filter's best loop-closure hypothesis per frame (its score, "
                            "0..1); green circles the right accepted closures, red crosses the "
                            "wrong ones; grey ticks mark frames that truly revisit a place, "
                            "orange ticks those of them the engine missed"
                          : "the filter's best loop-closure hypothesis per frame (its score, "
                            "0..1); purple circles the closures the engine accepted (no ground "
                            "truth: none is judged)"});
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
  if (stagePlot(folder, s))
    written.push_back({"time_by_stage.png",
                       "time per frame stacked by pipeline stage: where the time goes; a bad "
                       "frame is a gap"});
  return written;
}

}  // namespace placedb::cli
