#pragma once
// PNG figures of one run (the figures of paper 000), drawn with PLplot's pngcairo driver:
//   precision_recall.png   precision against recall over score thresholds, with the R@100P
//                          point and the engine's operating point (its accepted closures)
//   score.png              best hypothesis' score per frame; accepted closures right and wrong,
//                          ground-truth loop frames and the missed ones marked (without ground
//                          truth: the accepted closures, without a verdict)
//   vocabulary.png         vocabulary size per frame
//   quantisation_error.png mean quantisation error per frame
//   wm_size.png            working-memory size per frame
//   time.png               time per frame
//   time_by_stage.png      time per frame stacked by pipeline stage
// A series that is empty (its column was missing) is not drawn; a NaN value (a bad frame) is a
// gap in its line. `placedb eval` adds
// loop_matrix.png (loop_matrix.h).
#include <filesystem>
#include <string>
#include <vector>

#include "report/eval.h"

namespace placedb::cli {

struct RunSeries {
  // False without ground truth: the accepted closures (all in accepted_wrong) are shown without
  // a verdict, and no ground-truth frame is marked.
  bool judged = true;
  std::vector<double> frame;  // x of every series below
  std::vector<double> score, vocabulary_size, mean_quantisation_error, wm_size, time_ms;
  std::vector<double> accepted_right;  // frames whose accepted closure is right
  std::vector<double> accepted_wrong;  // frames whose accepted closure is wrong
  std::vector<double> gt_loop_frames;  // frames with a ground-truth loop
  std::vector<double> missed_loops;    // of those, the ones with no right accepted closure
  // Per-stage times in stacking order (an absent stage is left out); NaN for a bad frame.
  struct Stage {
    std::string name;
    std::vector<double> ms;
  };
  std::vector<Stage> stages;
};

struct WrittenPlot {
  std::string file;  // name inside the folder
  std::string what;  // one line for the newcomer
};

// Throws placedb::Error(kIo) when the folder cannot be made or PLplot lacks pngcairo.
// The precision-recall figure takes its curve and marked points from `evaluation`.
std::vector<WrittenPlot> writePlots(const RunSeries& series, const Evaluation& evaluation,
                                    const std::filesystem::path& folder);

bool pngPlottingAvailable();

}  // namespace placedb::cli
