#include "report/loop_matrix.h"

#include <algorithm>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "placedb/error.h"
#include "whole_file.h"

namespace placedb::cli {
namespace {

// Colours in OpenCV's BGR order, ranked so that a later one overwrites an earlier one.
const cv::Vec3b kWhite(255, 255, 255), kGreen(0, 200, 0), kRed(0, 0, 255), kYellow(0, 220, 255);

int rankOf(const cv::Vec3b& colour) {
  if (colour == kRed || colour == kYellow) return 3;
  if (colour == kGreen) return 2;
  if (colour == kWhite) return 1;
  return 0;
}

}  // namespace

WrittenPlot writeLoopMatrix(const Evaluation& evaluation, const GroundTruth& gt,
                            const std::filesystem::path& folder, bool judged) {
  std::int64_t frames = 1;
  for (const auto& f : evaluation.frames) {
    frames = std::max(frames, f.frame + 1);
    for (std::int64_t c : f.candidates) frames = std::max(frames, c + 1);
  }
  for (const auto& [q, refs] : gt) {
    frames = std::max(frames, q + 1);
    if (!refs.empty()) frames = std::max(frames, *refs.rbegin() + 1);
  }
  const std::int64_t shrink = (frames + kLoopMatrixMaxSide - 1) / kLoopMatrixMaxSide;
  const int side = static_cast<int>((frames + shrink - 1) / shrink);
  cv::Mat image(side, side, CV_8UC3, cv::Scalar(0, 0, 0));
  auto mark = [&](std::int64_t q, std::int64_t r, const cv::Vec3b& colour) {
    if (q < 0 || r < 0) return;
    cv::Vec3b& pixel =
        image.at<cv::Vec3b>(static_cast<int>(q / shrink), static_cast<int>(r / shrink));
    if (rankOf(colour) > rankOf(pixel)) pixel = colour;
  };
  for (const auto& [q, refs] : gt)
    for (std::int64_t r : refs) mark(q, r, kWhite);
  for (const auto& f : evaluation.frames) {
    if (!f.accepted) continue;
    for (std::int64_t c : f.candidates)
      mark(f.frame, c, !judged ? kYellow : f.correct ? kGreen : kRed);
  }
  std::vector<unsigned char> png;
  bool encoded = false;
  try {
    encoded = cv::imencode(".png", image, png);
  } catch (const cv::Exception&) {
    encoded = false;
  }
  const auto path = folder / "loop_matrix.png";
  if (!encoded) throw Error(ErrorCode::kIo, "cannot write " + path.string());
  writeWholeFile(path, std::string(png.begin(), png.end()));
  if (!judged)
    return {"loop_matrix.png",
            "the closures the engine accepted: frame down, the frame it closed on across, in "
            "yellow (no ground truth: none is judged)"};
  return {"loop_matrix.png",
          "loop pairs: frame down, earlier frame across; white missed, green right, red wrong"};
}

}  // namespace placedb::cli
