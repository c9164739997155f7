#pragma once
// Scores a per-frame log against ground-truth pairs with exactly the definitions of
// /work/shared/tools/score_loops.py (the reference), and prints the same text and JSON:
// recall at 100% precision, precision and recall of the accepted closures, time per frame.
// Python's rounding is reproduced: round-half-even percentile index, 2-decimal rounding of the
// exact binary value, shortest float representation.
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "frame_log.h"

namespace placedb::cli {

// Frame q -> the earlier frames r it revisits ("q r" lines, '#' comments).
using GroundTruth = std::map<std::int64_t, std::set<std::int64_t>>;
GroundTruth loadGroundTruth(const std::filesystem::path& path);

struct ScoredFrame {
  std::int64_t frame = 0;
  std::vector<std::int64_t> candidates;
  double score = 0;
  bool accepted = false;
  bool correct = false;  // a candidate within the window of a ground-truth reference
  std::optional<double> time_ms;
};

struct EvalFigures {
  std::int64_t frames = 0;
  std::int64_t gt_loop_frames = 0;
  int window = 0;
  double recall_at_100_precision = 0;        // percent, rounded to 2 decimals; NaN when no loop
  std::optional<double> accepted_precision;  // percent, None/null when undefined
  std::optional<double> accepted_recall;
  std::int64_t accepted_true = 0, accepted_false = 0;
  std::optional<double> time_ms_mean, time_ms_p50, time_ms_p99, time_ms_max;
  double wrong_bar = 0;  // best wrong score (-inf when there is none): the R@100P threshold
};

struct PrPoint {
  double threshold = 0;  // hypotheses scoring >= threshold count as declared
  double precision = 0, recall = 0;
};

struct Evaluation {
  std::vector<ScoredFrame> frames;  // in log order
  EvalFigures figures;
  std::vector<PrPoint> pr_curve;  // thresholds from the highest score down
};

// Throws placedb::Error(kInvalidArgument) when a scored column is missing or a value is bad.
Evaluation evaluate(const CsvTable& log, const GroundTruth& gt, int window);

// The figures as (key, value) in score_loops.py's order and text form, for other layouts.
std::vector<std::pair<std::string, std::string>> figureRows(const EvalFigures& figures);
// "key: value" lines, byte for byte as score_loops.py prints them.
std::string figuresText(const EvalFigures& figures);
// One JSON object, byte for byte as score_loops.py --json prints it (NaN where Python has NaN).
std::string figuresJson(const EvalFigures& figures);

// Python's repr() of a float and round(x, 2); exposed for the tests.
std::string pythonRepr(double value);
double pythonRound2(double value);
double pythonPercentile(std::vector<double> values, double p);

}  // namespace placedb::cli
