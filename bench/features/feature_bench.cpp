// Time per image of each extractor at three image sizes, single- and two-threaded.
//   placedb_bench_features [--images N] [--repeats R] [--datasets DIR] [--max-features N]
// Images: the first N/2 frames (every 25th) of lip6_outdoor and rtabmap_samples, resized.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "features/feature_extractor.h"
#include "features/image_conversion.h"
#include "features/opencv_extractors.h"

namespace {

using placedb::FeatureExtractor;
using placedb::FeatureOptions;

std::vector<std::string> framePaths(const std::filesystem::path& dataset, int count) {
  std::vector<std::string> paths;
  std::ifstream list(dataset / "frames.txt");
  std::string line;
  for (int index = 0; std::getline(list, line) && static_cast<int>(paths.size()) < count; ++index) {
    if (!line.empty() && index % 25 == 0) paths.push_back((dataset / line).string());
  }
  return paths;
}

struct Row {
  std::string label;
  double ms_per_image = 0;
  double mean_features = 0;
};

Row timeExtractor(const std::string& label, const FeatureExtractor& extractor,
                  const std::vector<cv::Mat>& images, int repeats) {
  extractor.extract(images.front());  // warm-up: lazy tables, OpenCV's thread pool
  std::size_t features = 0;
  const auto start = std::chrono::steady_clock::now();
  for (int r = 0; r < repeats; ++r) {
    for (const cv::Mat& image : images) features += extractor.extract(image).size();
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double runs = static_cast<double>(repeats) * images.size();
  return {label, 1000.0 * seconds / runs, features / runs};
}

}  // namespace

int main(int argc, char** argv) {
  int image_count = 12;
  int repeats = 3;
  int max_features = 0;  // a common cap makes the extractors' feature counts comparable
  std::filesystem::path datasets = PLACEDB_DATASETS_DIR;
  if (const char* env = std::getenv("PLACEDB_DATASETS")) datasets = env;
  const auto usage = [&](std::FILE* to, int code) {
    std::fprintf(to,
                 "usage: %s [--images N] [--repeats R] [--datasets DIR] [--max-features M]\n"
                 "Times each feature extractor on N frames of lip6_outdoor and rtabmap_samples\n"
                 "(PLACEDB_DATASETS or --datasets), R times over; see bench/features/README.md.\n",
                 argv[0]);
    return code;
  };
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "--help" || flag == "-h") return usage(stdout, 0);
  }
  if (argc % 2 == 0) return usage(stderr, 2);  // flags come in pairs
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--images")
      image_count = std::max(2, std::atoi(argv[i + 1]));
    else if (flag == "--repeats")
      repeats = std::max(1, std::atoi(argv[i + 1]));
    else if (flag == "--datasets")
      datasets = argv[i + 1];
    else if (flag == "--max-features")
      max_features = std::max(0, std::atoi(argv[i + 1]));
    else
      return usage(stderr, 2);
  }
  std::vector<cv::Mat> originals;
  for (const char* name : {"lip6_outdoor", "rtabmap_samples"}) {
    for (const auto& path : framePaths(datasets / name, image_count / 2)) {
      originals.push_back(placedb::loadGreyImage(path));
    }
  }
  if (originals.empty()) {
    std::fprintf(stderr, "no images found under %s\n", datasets.string().c_str());
    return 1;
  }
  std::printf("%zu images (lip6_outdoor + rtabmap_samples), %d repeats, %d hardware threads\n",
              originals.size(), repeats, cv::getNumberOfCPUs());

  const cv::Size sizes[] = {{240, 192}, {512, 384}, {640, 480}};
  for (const cv::Size& size : sizes) {
    std::vector<cv::Mat> images;
    for (const cv::Mat& original : originals) {
      cv::Mat resized;
      const bool shrink = size.area() < original.size().area();
      cv::resize(original, resized, size, 0, 0, shrink ? cv::INTER_AREA : cv::INTER_LINEAR);
      images.push_back(resized);
    }
    std::vector<Row> rows;
    double surf_ms[3] = {0, 0, 0}, sift_ms[3] = {0, 0, 0};
    for (int threads : {1, 2}) {
      cv::setNumThreads(threads);
      FeatureOptions options;
      options.threads = threads;
      options.hessian_threshold = 500;  // RTAB-Map's SURF default, which README.md's figures use
      options.max_features = max_features;
      const std::string suffix = " (" + std::to_string(threads) + "T)";
      for (const char* name : {"surf", "sift", "kaze", "orb"}) {
        options.extractor = name;
        auto extractor = placedb::makeFeatureExtractor(options, /*for_mapping=*/false);
        rows.push_back(timeExtractor(name + suffix, *extractor, images, repeats));
        if (options.extractor == "surf") surf_ms[threads] = rows.back().ms_per_image;
        if (options.extractor == "sift") sift_ms[threads] = rows.back().ms_per_image;
      }
    }
    std::printf("\n%dx%d\n%-12s %12s %12s\n", size.width, size.height, "extractor", "ms/image",
                "features");
    for (const Row& row : rows) {
      std::printf("%-12s %12.2f %12.0f\n", row.label.c_str(), row.ms_per_image, row.mean_features);
    }
    std::printf("SIFT/SURF time ratio: %.2fx (1 thread), %.2fx (2 threads)\n",
                sift_ms[1] / surf_ms[1], sift_ms[2] / surf_ms[2]);
  }
  return 0;
}
