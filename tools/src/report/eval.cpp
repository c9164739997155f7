#include "report/eval.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>

#include "placedb/error.h"
#include "text_file.h"

namespace placedb::cli {
namespace {

// Python's int(): surrounding blanks allowed, the rest must be a decimal integer.
std::int64_t parseInt(const std::string& text, const std::string& what) {
  std::string t = trim(text);
  errno = 0;
  char* end = nullptr;
  long long v = std::strtoll(t.c_str(), &end, 10);
  if (t.empty() || end != t.c_str() + t.size() || errno != 0)
    throw Error(ErrorCode::kInvalidArgument, fmt::format("{}: `{}` is not an integer", what, text));
  return v;
}

double parseFloat(const std::string& text, const std::string& what) {
  std::string t = trim(text);
  errno = 0;
  char* end = nullptr;
  double v = std::strtod(t.c_str(), &end);
  if (t.empty() || end != t.c_str() + t.size())
    throw Error(ErrorCode::kInvalidArgument, fmt::format("{}: `{}` is not a number", what, text));
  return v;
}

// Python's max(): keeps the first element unless a later one compares greater.
double pythonMax(const std::vector<double>& values) {
  double best = values.front();
  for (std::size_t i = 1; i < values.size(); ++i)
    if (values[i] > best) best = values[i];
  return best;
}

std::string jsonRepr(double value) {
  if (std::isnan(value)) return "NaN";
  if (std::isinf(value)) return value > 0 ? "Infinity" : "-Infinity";
  return pythonRepr(value);
}

std::vector<std::pair<std::string, std::string>> figureFields(const EvalFigures& f, bool json) {
  auto real = [json](double v) { return json ? jsonRepr(v) : pythonRepr(v); };
  auto optional = [json, &real](const std::optional<double>& v) {
    return v ? real(*v) : std::string(json ? "null" : "None");
  };
  return {{"frames", std::to_string(f.frames)},
          {"gt_loop_frames", std::to_string(f.gt_loop_frames)},
          {"window", std::to_string(f.window)},
          {"recall_at_100_precision", real(f.recall_at_100_precision)},
          {"accepted_precision", optional(f.accepted_precision)},
          {"accepted_recall", optional(f.accepted_recall)},
          {"accepted_true", std::to_string(f.accepted_true)},
          {"accepted_false", std::to_string(f.accepted_false)},
          {"time_ms_mean", optional(f.time_ms_mean)},
          {"time_ms_p50", optional(f.time_ms_p50)},
          {"time_ms_p99", optional(f.time_ms_p99)},
          {"time_ms_max", optional(f.time_ms_max)}};
}

std::vector<PrPoint> precisionRecallCurve(const std::vector<ScoredFrame>& frames,
                                          std::int64_t positives) {
  std::vector<const ScoredFrame*> with_hypothesis;
  for (const auto& f : frames)
    if (!f.candidates.empty() && !std::isnan(f.score)) with_hypothesis.push_back(&f);
  std::sort(with_hypothesis.begin(), with_hypothesis.end(),
            [](const ScoredFrame* a, const ScoredFrame* b) { return a->score > b->score; });
  std::vector<PrPoint> curve;
  std::int64_t declared = 0, right = 0;
  for (std::size_t i = 0; i < with_hypothesis.size(); ++i) {
    ++declared;
    if (with_hypothesis[i]->correct) ++right;
    // One point per distinct score: ties are declared together at that threshold.
    bool last_of_score = i + 1 == with_hypothesis.size() ||
                         with_hypothesis[i + 1]->score != with_hypothesis[i]->score;
    if (!last_of_score) continue;
    PrPoint point;
    point.threshold = with_hypothesis[i]->score;
    point.precision = static_cast<double>(right) / static_cast<double>(declared);
    point.recall = positives ? static_cast<double>(right) / static_cast<double>(positives) : 0.0;
    curve.push_back(point);
  }
  return curve;
}

}  // namespace

std::string pythonRepr(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  // fmt's shortest round-trip form switches to exponents where repr() does; repr() also keeps
  // a ".0" on integral values.
  std::string text = fmt::format("{}", value);
  if (text.find_first_of(".en") == std::string::npos) text += ".0";
  return text;
}

double pythonRound2(double value) {
  if (!std::isfinite(value)) return value;
  // printf rounds the exact binary value, ties to even: what Python's round(x, 2) does.
  std::string text = fmt::format("{:.2f}", value);
  return std::strtod(text.c_str(), nullptr);
}

double pythonPercentile(std::vector<double> values, double p) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  double position = p / 100.0 * static_cast<double>(values.size() - 1);
  // Python's round() on a float rounds half to even, as nearbyint does in the default mode.
  auto k = static_cast<std::int64_t>(std::nearbyint(position));
  k = std::min<std::int64_t>(static_cast<std::int64_t>(values.size()) - 1,
                             std::max<std::int64_t>(0, k));
  return values[static_cast<std::size_t>(k)];
}

GroundTruth loadGroundTruth(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw Error(ErrorCode::kIo, fmt::format("cannot read ground truth {}", path.string()));
  GroundTruth gt;
  std::string line;
  while (std::getline(in, line)) {
    if (auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    std::istringstream words(line);
    std::string q, r;
    if (!(words >> q >> r)) continue;
    gt[parseInt(q, path.string())].insert(parseInt(r, path.string()));
  }
  return gt;
}

Evaluation evaluate(const CsvTable& log, const GroundTruth& gt, int window) {
  const int frame_col = log.column("frame"), cand_col = log.column("candidate_frames"),
            score_col = log.column("score"), acc_col = log.column("accepted"),
            time_col = log.column("time_ms");
  std::vector<std::string> missing;
  if (frame_col < 0) missing.push_back("'frame'");
  if (cand_col < 0) missing.push_back("'candidate_frames'");
  if (score_col < 0) missing.push_back("'score'");
  if (acc_col < 0) missing.push_back("'accepted'");
  if (!missing.empty()) {
    std::sort(missing.begin(), missing.end());
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("log lacks columns [{}]", fmt::join(missing, ", ")));
  }

  Evaluation eval;
  std::vector<double> times;
  std::set<std::int64_t> seen;
  for (std::size_t i = 0; i < log.rows.size(); ++i) {
    ScoredFrame f;
    std::string where = fmt::format("log row {}", i + 2);
    f.frame = parseInt(log.cell(i, frame_col), where);
    std::string cands = log.cell(i, cand_col);
    std::replace(cands.begin(), cands.end(), ';', ' ');
    std::istringstream words(cands);
    for (std::string word; words >> word;) f.candidates.push_back(parseInt(word, where));
    const std::string& score = log.cell(i, score_col);
    f.score = score.empty() ? 0.0 : parseFloat(score, where);
    std::string accepted = trim(log.cell(i, acc_col));
    f.accepted = accepted == "1" || accepted == "true" || accepted == "True";
    if (!log.cell(i, time_col).empty()) {
      f.time_ms = parseFloat(log.cell(i, time_col), where);
      times.push_back(*f.time_ms);
    }
    auto refs = gt.find(f.frame);
    if (refs != gt.end())
      for (std::int64_t c : f.candidates)
        for (std::int64_t r : refs->second)
          if (std::llabs(c - r) <= window) f.correct = true;
    // A frame twice (rows left behind by a run whose last commits were lost) would count its
    // loop twice and lift recall above 100 %.
    if (!seen.insert(f.frame).second)
      throw Error(ErrorCode::kInvalidArgument,
                  fmt::format("{}: frame {} appears twice in the log", where, f.frame));
    eval.frames.push_back(std::move(f));
  }

  EvalFigures& out = eval.figures;
  out.frames = static_cast<std::int64_t>(eval.frames.size());
  out.window = window;
  for (const auto& [q, refs] : gt)
    if (seen.count(q)) ++out.gt_loop_frames;
  const auto positives = static_cast<double>(out.gt_loop_frames);
  const double nan = std::numeric_limits<double>::quiet_NaN();

  std::vector<double> wrong_scores;
  for (const auto& f : eval.frames)
    if (!f.candidates.empty() && !f.correct) wrong_scores.push_back(f.score);
  out.wrong_bar =
      wrong_scores.empty() ? -std::numeric_limits<double>::infinity() : pythonMax(wrong_scores);
  std::int64_t tp_at_100 = 0;
  for (const auto& f : eval.frames) {
    if (!f.candidates.empty() && f.correct && f.score > out.wrong_bar) ++tp_at_100;
    bool right = !f.candidates.empty() && f.correct;
    if (f.accepted && right) ++out.accepted_true;
    if (f.accepted && !right) ++out.accepted_false;
  }
  double r100 = out.gt_loop_frames ? static_cast<double>(tp_at_100) / positives : nan;
  out.recall_at_100_precision = pythonRound2(100 * r100);
  std::int64_t declared = out.accepted_true + out.accepted_false;
  if (declared)
    out.accepted_precision = pythonRound2(
        100 * (static_cast<double>(out.accepted_true) / static_cast<double>(declared)));
  if (out.gt_loop_frames)
    out.accepted_recall = pythonRound2(100 * (static_cast<double>(out.accepted_true) / positives));

  if (!times.empty()) {
    double sum = 0;
    for (double t : times) sum += t;  // left to right, as Python 3.11's sum()
    out.time_ms_mean = pythonRound2(sum / static_cast<double>(times.size()));
    out.time_ms_p50 = pythonPercentile(times, 50);
    out.time_ms_p99 = pythonPercentile(times, 99);
    out.time_ms_max = pythonMax(times);
  }
  eval.pr_curve = precisionRecallCurve(eval.frames, out.gt_loop_frames);
  return eval;
}

std::vector<std::pair<std::string, std::string>> figureRows(const EvalFigures& figures) {
  return figureFields(figures, false);
}

std::string figuresText(const EvalFigures& figures) {
  std::string text;
  for (const auto& [key, value] : figureRows(figures)) text += fmt::format("{}: {}\n", key, value);
  return text;
}

std::string figuresJson(const EvalFigures& figures) {
  std::string text = "{";
  for (const auto& [key, value] : figureFields(figures, true))
    text += fmt::format("{}\"{}\": {}", text.size() > 1 ? ", " : "", key, value);
  return text + "}\n";
}

}  // namespace placedb::cli
