// Diagnostic: the geometric check of one image against another, as the engine runs it on a
// frame and a candidate (descriptor matches only: a lone pair of images has no words), with
// the engine's feature settings. Prints the result and, with --dump DIR, writes each image's
// keypoints and descriptors and the check's agreeing pairs as text, to look at with other tools.
//
//   placedb_check_probe QUERY.png CANDIDATE.png [--dump DIR] [--set key=value]...
#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "features/feature_extractor.h"
#include "features/image_conversion.h"
#include "geometry/geometric_check.h"
#include "map/option_mapping.h"
#include "placedb/options.h"

namespace {

void dumpFeatures(const placedb::Features& f, const std::filesystem::path& file) {
  std::ofstream out(file);
  for (std::size_t i = 0; i < f.size(); ++i) {
    const auto& k = f.keypoints[i];
    out << fmt::format("{:.2f} {:.2f} {:.2f} {:.1f} {:.3g}", k.x, k.y, k.size, k.angle, k.response);
    for (int c = 0; c < f.descriptors.cols; ++c)
      out << ' ' << f.descriptors.at<float>(static_cast<int>(i), c);
    out << '\n';
  }
}

placedb::GeometricView viewOf(const placedb::Features& f) {
  placedb::GeometricView v;
  for (const auto& k : f.keypoints) v.points.emplace_back(k.x, k.y);
  v.descriptors = f.descriptors;
  v.image_size = f.image_size;
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    fmt::print(stderr, "usage: {} QUERY CANDIDATE [--dump DIR] [--set key=value]...\n", argv[0]);
    return 2;
  }
  try {
    std::map<std::string, std::string> settings;
    std::string dump;
    for (int a = 3; a + 1 < argc; a += 2) {
      const std::string key = argv[a], value = argv[a + 1];
      if (key == "--dump") {
        dump = value;
      } else if (key == "--set") {
        const auto eq = value.find('=');
        settings[value.substr(0, eq)] = value.substr(eq + 1);
      }
    }
    const placedb::Options options = placedb::Options::fromSettings(settings);
    const auto extractor = placedb::makeFeatureExtractor(placedb::toFeatureOptions(options));
    const placedb::Features q = extractor->extract(placedb::loadGreyImage(argv[1]));
    const placedb::Features c = extractor->extract(placedb::loadGreyImage(argv[2]));
    placedb::GeometricView query = viewOf(q), candidate = viewOf(c);
    candidate.image_size = {};
    const auto settings_check = placedb::toGeometricCheckSettings(options);
    const placedb::GeometricResult g = placedb::checkGeometry(query, candidate, settings_check);
    const placedb::GeometricResult cmp = placedb::compareGeometry(query, candidate, settings_check);
    fmt::print("keypoints {} / {}; check: {} inliers of {} matches, log10 NFA {:.2f}, passed {}\n",
               q.size(), c.size(), g.inliers, g.matches, g.log10_nfa, g.passed);
    fmt::print("compare: {} inliers of {} matches, log10 NFA {:.2f}, passed {}\n", cmp.inliers,
               cmp.matches, cmp.log10_nfa, cmp.passed);
    if (!dump.empty()) {
      std::filesystem::create_directories(dump);
      dumpFeatures(q, std::filesystem::path(dump) / "query.txt");
      dumpFeatures(c, std::filesystem::path(dump) / "candidate.txt");
      std::ofstream pairs(std::filesystem::path(dump) / "agreeing.txt");
      for (std::size_t i = 0; i < cmp.agreeing_query.size(); ++i)
        pairs << fmt::format("{:.2f} {:.2f} {:.2f} {:.2f}\n", cmp.agreeing_query[i].x,
                             cmp.agreeing_query[i].y, cmp.agreeing_candidate[i].x,
                             cmp.agreeing_candidate[i].y);
    }
    return 0;
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 1;
  }
}
