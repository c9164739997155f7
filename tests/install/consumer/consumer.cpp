// Maps three images through an installed placedb and prints what the map then holds.
// Usage: consumer MAP [IMAGE...]; without images it draws three (the third revisits the first).
#include <placedb/map.h>

#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

namespace {

cv::Mat drawnImage(int seed) {
  cv::Mat image(240, 320, CV_8UC3);
  cv::RNG rng(seed);
  rng.fill(image, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(image, image, cv::Size(5, 5), 1.5);
  return image;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: consumer MAP [IMAGE...]\n");
    return 2;
  }
  std::vector<cv::Mat> images;
  std::vector<std::string> names;
  for (int i = 2; i < argc; ++i) {
    images.push_back(cv::imread(argv[i], cv::IMREAD_COLOR));
    names.push_back(argv[i]);
    if (images.back().empty()) {
      std::fprintf(stderr, "consumer: cannot read %s\n", argv[i]);
      return 3;
    }
  }
  if (images.empty()) {
    for (int seed : {1, 2, 1}) {
      images.push_back(drawnImage(seed));
      names.push_back("drawn-" + std::to_string(seed));
    }
  }
  try {
    auto map = placedb::Map::open(argv[1], placedb::Options());
    map->beginSession("consumer");
    for (std::size_t i = 0; i < images.size(); ++i) {
      placedb::FrameResult r = map->process(images[i], static_cast<std::int64_t>(i), names[i]);
      std::printf("frame %lld: %zu features, location %lld\n", static_cast<long long>(r.frame_id),
                  r.feature_count, static_cast<long long>(r.location_id));
    }
    map->close();
    auto reopened =
        placedb::Map::open(argv[1], placedb::Options(), placedb::Map::Mode::kLocalisation);
    std::printf("frames in map: %lld\n", static_cast<long long>(reopened->lastSession()->frames));
  } catch (const placedb::Error& e) {
    std::fprintf(stderr, "consumer: %s\n", e.what());
    return 4;
  }
  return 0;
}
