// Writes a resized copy of every image of a frame list, for benchmarks at another resolution
// (bench/quality/verification_timing.py: lip6_outdoor at 960x540). The copies keep their file
// names; the aspect ratio is not kept when WIDTH x HEIGHT asks otherwise. A smaller copy averages
// the pixels it covers (what a camera of that resolution would see), a larger one is cubic.
//
//   placedb_resize_frames LIST OUT_DIR WIDTH HEIGHT
#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "image_source.h"  // the CLI's list-file reader: same rules as `placedb map`

int main(int argc, char** argv) {
  if (argc != 5) {
    fmt::print(stderr, "usage: {} LIST OUT_DIR WIDTH HEIGHT\n", argv[0]);
    return 2;
  }
  const std::filesystem::path out = argv[2];
  const cv::Size size(std::atoi(argv[3]), std::atoi(argv[4]));
  if (size.width <= 0 || size.height <= 0) {
    fmt::print(stderr, "WIDTH and HEIGHT must be positive\n");
    return 2;
  }
  try {
    std::filesystem::create_directories(out);
    for (const auto& frame : placedb::cli::readListFile(argv[1])) {
      const cv::Mat image = cv::imread(frame, cv::IMREAD_UNCHANGED);
      if (image.empty()) {
        fmt::print(stderr, "cannot read {}\n", frame);
        return 1;
      }
      cv::Mat resized;
      // Cubic: an upscaled frame should look like a sharp camera's, not a blocky one.
      const bool smaller = size.area() < image.size().area();
      cv::resize(image, resized, size, 0, 0, smaller ? cv::INTER_AREA : cv::INTER_CUBIC);
      const auto target = out / std::filesystem::path(frame).filename();
      if (!cv::imwrite(target.string(), resized)) {
        fmt::print(stderr, "cannot write {}\n", target.string());
        return 1;
      }
    }
    return 0;
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 1;
  }
}
