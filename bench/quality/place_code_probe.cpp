// Measures how well place codes (memory/place_code.h) find a revisited place among all earlier
// frames, as LTM search would: for every frame with a ground-truth loop, the earlier frames at
// least --gap frames back are ranked by code similarity, and a hit at k is a frame among the
// top k within --window frames of a ground-truth reference. Features use the engine defaults;
// the centres are trained on the first frame, as a map does.
//
//   placedb_place_code_probe LIST GT [--gap 30] [--window 2] [--configs 16:256,32:256]
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "features/feature_extractor.h"
#include "features/image_conversion.h"
#include "map/option_mapping.h"
#include "memory/place_code.h"
#include "placedb/options.h"

namespace fs = std::filesystem;
using namespace placedb;

int main(int argc, char** argv) {
  if (argc < 3) {
    fmt::print(stderr, "usage: {} LIST GT [--gap N] [--window N] [--configs K:D,...]\n", argv[0]);
    return 2;
  }
  int gap = 30, window = 2, train_frames = 1;
  std::string configs = "16:256";
  for (int i = 3; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--gap") gap = std::stoi(argv[i + 1]);
    if (flag == "--window") window = std::stoi(argv[i + 1]);
    if (flag == "--configs") configs = argv[i + 1];
    if (flag == "--train-frames") train_frames = std::stoi(argv[i + 1]);
  }
  const fs::path list = argv[1];
  std::vector<std::string> frames;
  {
    std::ifstream in(list);
    for (std::string line; std::getline(in, line);)
      if (!line.empty() && line[0] != '#') frames.push_back((list.parent_path() / line).string());
  }
  std::map<int, std::set<int>> truth;
  {
    std::ifstream in(argv[2]);
    for (std::string line; std::getline(in, line);) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream fields(line);
      int q = 0, r = 0;
      if (fields >> q >> r) truth[q].insert(r);
    }
  }
  auto extractor = makeFeatureExtractor(toFeatureOptions(Options()));
  std::vector<cv::Mat> descriptors;
  for (const auto& f : frames)
    descriptors.push_back(extractor->extract(loadGreyImage(f)).descriptors);
  fmt::print("{} frames, {} with a loop\n", frames.size(), truth.size());

  auto evaluate = [&](const std::string& name, auto&& similarity) {
    const int ks[] = {1, 3, 5, 10, 20};
    int hits[5] = {0, 0, 0, 0, 0}, asked = 0;
    for (const auto& [q, refs] : truth) {
      if (q >= int(frames.size()) || q - gap < 1) continue;
      std::vector<std::pair<double, int>> ranked;
      for (int r = 0; r <= q - gap; ++r) ranked.emplace_back(-similarity(q, r), r);
      std::sort(ranked.begin(), ranked.end());
      ++asked;
      for (int k = 0; k < 5; ++k)
        for (int i = 0; i < std::min<int>(ks[k], int(ranked.size())); ++i) {
          auto near = refs.lower_bound(ranked[i].second - window);
          if (near != refs.end() && *near <= ranked[i].second + window) {
            ++hits[k];
            break;
          }
        }
    }
    fmt::print("{}: of {} loop frames, found at top", name, asked);
    for (int k = 0; k < 5; ++k)
      fmt::print(" {}: {:.1f} %", ks[k], 100.0 * hits[k] / std::max(asked, 1));
    fmt::print("\n");
  };
  for (int words : {256, 1024, 4096}) {
    cv::Mat training;
    for (int f = 0; f < train_frames && f < int(descriptors.size()); ++f)
      training.push_back(descriptors[f]);
    // two-level tree: sqrt(words) x sqrt(words)
    const int b = int(std::lround(std::sqrt(double(words))));
    cv::Mat labels, top;
    cv::setRNGSeed(1);
    cv::kmeans(training, b, labels, cv::TermCriteria(cv::TermCriteria::COUNT, 10, 0), 1,
               cv::KMEANS_PP_CENTERS, top);
    std::vector<cv::Mat> sub(b);
    for (int c = 0; c < b; ++c) {
      cv::Mat part;
      for (int i = 0; i < training.rows; ++i)
        if (labels.at<int>(i) == c) part.push_back(training.row(i));
      cv::Mat l2;
      if (part.rows >= b)
        cv::kmeans(part, b, l2, cv::TermCriteria(cv::TermCriteria::COUNT, 10, 0), 1,
                   cv::KMEANS_PP_CENTERS, sub[c]);
      else
        sub[c] = part.rows ? part : top.row(c);
    }
    auto nearest = [](const cv::Mat& centres, const float* row) {
      int best = 0;
      float bd = 1e30f;
      for (int c = 0; c < centres.rows; ++c) {
        float d = 0;
        const float* x = centres.ptr<float>(c);
        for (int j = 0; j < centres.cols; ++j) {
          float t = x[j] - row[j];
          d += t * t;
        }
        if (d < bd) {
          bd = d;
          best = c;
        }
      }
      return best;
    };
    std::vector<std::map<int, double>> bows(frames.size());
    std::vector<double> df(b * b, 0.0);
    for (std::size_t f = 0; f < frames.size(); ++f) {
      for (int i = 0; i < descriptors[f].rows; ++i) {
        const float* row = descriptors[f].ptr<float>(i);
        const int c = nearest(top, row);
        bows[f][c * b + nearest(sub[c], row)] += 1.0;
      }
      for (auto& [w, n] : bows[f]) df[w] += 1;
    }
    for (auto& bow : bows) {
      double norm = 0;
      for (auto& [w, n] : bow) {
        n = n * std::log(double(frames.size()) / df[w]);
        norm += n * n;
      }
      norm = std::sqrt(norm);
      for (auto& [w, n] : bow) n /= norm;
    }
    evaluate(fmt::format("coarse BoW {} words", b * b), [&](int q, int r) {
      double s = 0;
      for (const auto& [w, n] : bows[q]) {
        auto it = bows[r].find(w);
        if (it != bows[r].end()) s += n * it->second;
      }
      return s;
    });
  }
  std::stringstream items(configs);
  for (std::string item; std::getline(items, item, ',');) {
    PlaceCodeSettings settings;
    std::sscanf(item.c_str(), "%d:%d", &settings.centres, &settings.code_dim);
    const auto start = std::chrono::steady_clock::now();
    cv::Mat training;
    for (int f = 0; f < train_frames && f < int(descriptors.size()); ++f)
      training.push_back(descriptors[f]);
    const PlaceCoder coder = PlaceCoder::train(training, settings);
    std::vector<std::vector<std::int8_t>> codes;
    for (const auto& d : descriptors) codes.push_back(coder.encode(d));
    const double encode_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
            .count() /
        double(frames.size());
    const int ks[] = {1, 3, 5, 10, 20};
    int hits[5] = {0, 0, 0, 0, 0}, asked = 0;
    for (const auto& [q, refs] : truth) {
      if (q >= int(codes.size()) || q - gap < 1) continue;
      std::vector<std::pair<double, int>> ranked;
      for (int r = 0; r <= q - gap; ++r)
        ranked.emplace_back(-codeSimilarity(codes[q].data(), codes[r].data(), settings.code_dim),
                            r);
      std::sort(ranked.begin(), ranked.end());
      ++asked;
      for (int k = 0; k < 5; ++k) {
        for (int i = 0; i < std::min<int>(ks[k], int(ranked.size())); ++i) {
          const int r = ranked[i].second;
          auto near = refs.lower_bound(r - window);
          if (near != refs.end() && *near <= r + window) {
            ++hits[k];
            break;
          }
        }
      }
    }
    fmt::print("K={:3} code_dim={:4}: encode {:.2f} ms/frame; of {} loop frames, found at top",
               settings.centres, settings.code_dim, encode_ms, asked);
    for (int k = 0; k < 5; ++k)
      fmt::print(" {}: {:.1f} %", ks[k], 100.0 * hits[k] / std::max(asked, 1));
    fmt::print("\n");
  }
  return 0;
}
