// Maps one frame list straight through with the given settings and writes the per-frame log
// (EVALUATION.md columns, then diagnostic ones) plus one JSON line of run-wide figures:
// final vocabulary size, mean quantisation error, time per frame and peak RSS.
//
//   placedb_quality_run LIST --log OUT.csv [--map OUT.placedb] [--set key=value]...
//
// bench/quality/run.py calls it once per sequence and word rule and scores the logs.
#include <fmt/format.h>
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "features/image_conversion.h"
#include "placedb/map.h"
#include "placedb/storage/map_files.h"
#include "sources/image_source.h"  // the CLI's list-file reader: same rules as `placedb map`

namespace fs = std::filesystem;

namespace {

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  auto k = static_cast<std::size_t>(std::lround(p / 100.0 * static_cast<double>(v.size() - 1)));
  return v[std::min(v.size() - 1, k)];
}

std::string candidatesOf(const placedb::FrameResult& r) {
  std::string out;
  for (const auto& f : r.hypothesis.frames)
    if (f.session_id == r.session_id)
      out += (out.empty() ? "" : " ") + std::to_string(f.source_index);
  return out;
}

double peakRssMb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux reports kilobytes
}

}  // namespace

int main(int argc, char** argv) {
  const bool help = argc == 2 && (std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h");
  if (argc < 2 || help) {
    fmt::print(help ? stdout : stderr,
               "usage: {} LIST --log OUT.csv [--map OUT.placedb] [--set key=value]...\n"
               "Maps the frames of LIST into a new map (a temporary one unless --map) and writes\n"
               "the EVALUATION.md log with diagnostic columns; prints one JSON line of totals.\n",
               argv[0]);
    return help ? 0 : 2;
  }
  const fs::path list = argv[1];
  fs::path log_path = "quality.csv", map_path;
  std::map<std::string, std::string> settings;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string flag = argv[i], value = argv[i + 1];
    if (flag == "--log") {
      log_path = value;
    } else if (flag == "--map") {
      map_path = value;
    } else if (flag == "--set" && value.find('=') != std::string::npos) {
      settings[value.substr(0, value.find('='))] = value.substr(value.find('=') + 1);
    } else {
      fmt::print(stderr, "unknown flag or malformed value: {} {}\n", flag, value);
      return 2;
    }
  }
  if (map_path.empty()) map_path = fs::path(log_path).replace_extension(".placedb");
  try {
    const auto options = placedb::Options::fromSettings(settings);
    const auto frames = placedb::cli::readListFile(list);
    placedb::storage::removeMap(map_path.string());
    auto map = placedb::Map::open(map_path.string(), options);
    map->beginSession(list.string());

    std::ofstream log(log_path);
    log << "frame,candidate_frames,score,accepted,time_ms,location,outcome,hypothesis,"
           "posterior,reason,words,quantisation_error,inliers,matches,verification_ms,"
           "candidates_checked,filter_ms,log10_nfa,evidence_frames\n";
    std::vector<double> times;
    double error_sum = 0;
    std::size_t error_features = 0, vocabulary = 0;
    for (std::size_t i = 0; i < frames.size(); ++i) {
      const auto r =
          map->process(placedb::loadGreyImage(frames[i]), static_cast<std::int64_t>(i), frames[i]);
      times.push_back(r.times.total);
      // Feature-weighted, so the mean is over features as in paper 000's figure.
      error_sum += r.mean_quantisation_error * static_cast<double>(r.feature_count);
      error_features += r.outcome == placedb::FrameOutcome::kBad ? 0 : r.feature_count;
      vocabulary = r.vocabulary_size;
      log << fmt::format(
          "{},{},{:.17g},{},{:.3f},{},{},{},{:.6g},\"{}\",{},{:.6g},{},{},{:.3f},{},{:.3f},{:.2f},{"
          "}"
          "\n",
          i, candidatesOf(r), r.hypothesis.score, r.hypothesis.accepted ? 1 : 0, r.times.total,
          r.location_id, static_cast<int>(r.outcome), r.hypothesis.location_id,
          r.hypothesis.posterior, r.hypothesis.rejected_reason, r.feature_count,
          r.mean_quantisation_error, r.hypothesis.inliers, r.hypothesis.matches,
          r.times.verification, r.hypothesis.candidates_checked, r.times.filter,
          r.hypothesis.log10_nfa, r.hypothesis.evidence_frames);
    }
    map->close();
    double mean = 0;
    for (double t : times) mean += t;
    mean /= static_cast<double>(std::max<std::size_t>(1, times.size()));
    fmt::print(
        "{{\"frames\": {}, \"vocabulary_size\": {}, \"mean_quantisation_error\": {:.6g}, "
        "\"time_ms_mean\": {:.2f}, \"time_ms_p99\": {:.2f}, \"time_ms_max\": {:.2f}, "
        "\"peak_rss_mb\": {:.1f}}}\n",
        frames.size(), vocabulary, error_features ? error_sum / double(error_features) : 0.0, mean,
        percentile(times, 99), times.empty() ? 0.0 : *std::max_element(times.begin(), times.end()),
        peakRssMb());
    return 0;
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 1;
  }
}
