#pragma once
// PNG figures of one run (the figures of paper 000), drawn with PLplot's pngcairo driver:
//   precision_recall.png   precision against recall over score thresholds
//   score.png              best hypothesis' score per frame, ground-truth loop frames marked,
//                          accepted closures marked
//   vocabulary.png         vocabulary size per frame
//   quantisation_error.png mean quantisation error per frame
//   wm_size.png            working-memory size per frame
//   time.png               time per frame
// A series that is empty (its column was missing) is not drawn; a NaN value (a bad frame) is a
// gap in its line. `placedb eval` adds
// loop_matrix.png (loop_matrix.h).
#include <filesystem>
#include <string>
#include <vector>

#include "eval.h"

namespace placedb::cli {

struct RunSeries {
  std::vector<double> frame;  // x of every series below
  std::vector<double> score, vocabulary_size, mean_quantisation_error, wm_size, time_ms;
  std::vector<double> accepted_frames;  // frames where a closure was accepted
  std::vector<double> gt_loop_frames;   // frames with a ground-truth loop
};

struct WrittenPlot {
  std::string file;  // name inside the folder
  std::string what;  // one line for the newcomer
};

// Throws placedb::Error(kIo) when the folder cannot be made or PLplot lacks pngcairo.
std::vector<WrittenPlot> writePlots(const RunSeries& series, const std::vector<PrPoint>& pr_curve,
                                    const std::filesystem::path& folder);

bool pngPlottingAvailable();

}  // namespace placedb::cli
