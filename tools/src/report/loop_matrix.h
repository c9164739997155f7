#pragma once
// The detected-vs-ground-truth loop matrix, in the form of RTAB-Map's samples_GT.bmp: one pixel
// per pair (frame q down, earlier frame r across) on black,
//   white  a ground-truth loop pair that no accepted closure found
//   green  an accepted closure whose candidate is right (within the window of the truth)
//   red    an accepted closure whose candidate is wrong
// Without ground truth (judged false) it is the matrix of the accepted closures alone, each pair
// yellow. A run longer than kLoopMatrixMaxSide frames is shrunk by a whole factor; where pairs
// share a pixel, red wins over green and green over white, so no wrong closure is hidden.
#include <filesystem>

#include "report/eval.h"
#include "report/plots.h"

namespace placedb::cli {

constexpr int kLoopMatrixMaxSide = 1000;

// Writes loop_matrix.png into `folder` (which must exist). Throws placedb::Error(kIo) when it
// cannot be written.
WrittenPlot writeLoopMatrix(const Evaluation& evaluation, const GroundTruth& gt,
                            const std::filesystem::path& folder, bool judged = true);

}  // namespace placedb::cli
