// Writes a resized copy of every image of a frame list, for benchmarks at another resolution
// (bench/quality/verification_timing.py: lip6_outdoor at 960x540). The copies keep their file
// names; the aspect ratio is not kept when WIDTH x HEIGHT asks otherwise. A smaller copy averages
// the pixels it covers (what a camera of that resolution would see), a larger one is cubic.
// Options make another camera of the same walk (bench/quality/unseen_derivations.py): --mirror
// flips each image left to right (SURF is not mirror-invariant, so every descriptor changes),
// --noise SIGMA adds Gaussian noise of SIGMA grey levels (seeded by the image's place in the list,
// so a copy is the same every time), --gamma G --gain K maps v to 255 K (v / 255)^G (G > 1 and
// K < 1: a darker, lower-contrast camera).
//
//   placedb_resize_frames LIST OUT_DIR WIDTH HEIGHT [--mirror] [--noise SIGMA] [--gamma G]
//                         [--gain K]
#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "sources/image_source.h"  // the CLI's list-file reader: same rules as `placedb map`

namespace {

struct Look {
  bool mirror = false;
  double noise = 0;  // grey levels
  double gamma = 1, gain = 1;
};

// The options after the four positional arguments; false on anything else.
bool parseLook(int argc, char** argv, Look& look) {
  for (int i = 5; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "--mirror") {
      look.mirror = true;
      continue;
    }
    if (i + 1 >= argc) return false;
    const double value = std::atof(argv[++i]);
    if (flag == "--noise" && value >= 0)
      look.noise = value;
    else if (flag == "--gamma" && value > 0)
      look.gamma = value;
    else if (flag == "--gain" && value > 0)
      look.gain = value;
    else
      return false;
  }
  return true;
}

cv::Mat changeLook(cv::Mat image, const Look& look, int index) {
  if (look.mirror) cv::flip(image, image, 1);
  if (look.gamma != 1 || look.gain != 1) {
    cv::Mat v;
    image.convertTo(v, CV_32F, 1.0 / 255);
    cv::pow(v, look.gamma, v);
    v.convertTo(image, image.type(), 255 * look.gain);
  }
  if (look.noise > 0) {
    cv::Mat noise(image.size(), CV_MAKETYPE(CV_32F, image.channels()));
    cv::RNG rng(static_cast<std::uint64_t>(index) + 1);
    rng.fill(noise, cv::RNG::NORMAL, 0, look.noise);
    cv::Mat v;
    image.convertTo(v, CV_32F);
    v += noise;
    v.convertTo(image, image.type());  // saturates
  }
  return image;
}

}  // namespace

int main(int argc, char** argv) {
  Look look;
  if (argc < 5 || !parseLook(argc, argv, look)) {
    fmt::print(stderr,
               "usage: {} LIST OUT_DIR WIDTH HEIGHT [--mirror] [--noise SIGMA] [--gamma G] "
               "[--gain K]\n",
               argv[0]);
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
    int index = 0;
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
      resized = changeLook(resized, look, index++);
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
