// Maps a sequence straight and again stopped-and-resumed at a frame, with the memory settings
// given, checks that both runs log the same results, and prints time per stage (p50/p99).
//
//   placedb_engine_bench LIST [--resume-at N] [--set key=value]... [--log-dir DIR] [--limit N]
//
// LIST is a frames.txt (image paths relative to its folder), e.g. ../shared/datasets/lip6_outdoor.
#include <fmt/format.h>
#include <fmt/ranges.h>

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
using placedb::FrameResult;

namespace {

struct Row {
  std::string candidates;
  double score = 0, posterior = 0;
  bool accepted = false;
  placedb::StageTimes times;
};

Row toRow(const FrameResult& r) {
  Row row;
  for (const auto& f : r.hypothesis.frames)
    if (f.session_id == r.session_id)
      row.candidates += (row.candidates.empty() ? "" : " ") + std::to_string(f.source_index);
  row.score = r.hypothesis.score;
  row.posterior = r.hypothesis.posterior;
  row.accepted = r.hypothesis.accepted;
  row.times = r.times;
  return row;
}

// Maps frames [from, to) of the list into the map, resuming its last session when from > 0.
void run(const std::string& map_path, const std::vector<std::string>& frames,
         const placedb::Options& options, std::size_t from, std::size_t to,
         std::vector<Row>& rows) {
  auto map = placedb::Map::open(map_path, options);
  if (from == 0)
    map->beginSession("bench");
  else
    map->resumeSession(map->lastSession()->id);
  for (std::size_t i = from; i < to; ++i) {
    FrameResult r =
        map->process(placedb::loadGreyImage(frames[i]), static_cast<std::int64_t>(i), frames[i]);
    rows.push_back(toRow(r));
    if ((i + 1) % 100 == 0)
      fmt::print(stderr, "  frame {}/{}: wm {} stm {} vocabulary {}\n", i + 1, frames.size(),
                 r.wm_size, r.stm_size, r.vocabulary_size);
  }
  map->close();
}

void writeLog(const fs::path& path, const std::vector<Row>& rows) {
  std::ofstream out(path);
  out << "frame,candidate_frames,score,accepted,time_ms\n";
  for (std::size_t i = 0; i < rows.size(); ++i)
    out << fmt::format("{},{},{:.17g},{},{:.3f}\n", i, rows[i].candidates, rows[i].score,
                       rows[i].accepted ? 1 : 0, rows[i].times.total);
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1,
                    static_cast<std::size_t>(std::lround(p / 100.0 * (v.size() - 1))))];
}

void printStages(const char* title, const std::vector<Row>& rows) {
  using Member = double placedb::StageTimes::*;
  const std::pair<const char*, Member> stages[] = {
      {"features", &placedb::StageTimes::features},
      {"quantisation", &placedb::StageTimes::quantisation},
      {"likelihood", &placedb::StageTimes::likelihood},
      {"filter", &placedb::StageTimes::filter},
      {"memory", &placedb::StageTimes::memory},
      {"storage", &placedb::StageTimes::storage},
      {"total", &placedb::StageTimes::total}};
  fmt::print("{}\n  {:<14}{:>10}{:>10}{:>10}\n", title, "stage", "p50 ms", "p99 ms", "max ms");
  for (auto [name, member] : stages) {
    std::vector<double> v;
    for (const auto& r : rows) v.push_back(r.times.*member);
    fmt::print("  {:<14}{:>10.2f}{:>10.2f}{:>10.2f}\n", name, percentile(v, 50), percentile(v, 99),
               *std::max_element(v.begin(), v.end()));
  }
}

}  // namespace

int main(int argc, char** argv) {
  const bool help = argc == 2 && (std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h");
  if (argc < 2 || help) {
    fmt::print(help ? stdout : stderr,
               "usage: {} LIST [--resume-at N] [--set key=value]... [--log-dir DIR] "
               "[--limit N]\n",
               argv[0]);
    return help ? 0 : 2;
  }
  fs::path list = argv[1];
  std::size_t resume_at = 500, limit = 0;
  fs::path log_dir = fs::temp_directory_path() / "placedb-engine-bench";
  std::map<std::string, std::string> settings;
  for (int i = 2; i + 1 < argc; i += 2) {
    std::string flag = argv[i], value = argv[i + 1];
    if (flag == "--resume-at")
      resume_at = std::stoul(value);
    else if (flag == "--limit")
      limit = std::stoul(value);
    else if (flag == "--log-dir")
      log_dir = value;
    else if (flag == "--set")
      settings[value.substr(0, value.find('='))] = value.substr(value.find('=') + 1);
    else {
      fmt::print(stderr, "unknown flag {}\n", flag);
      return 2;
    }
  }
  try {
    auto options = placedb::Options::fromSettings(settings);
    auto frames = placedb::cli::readListFile(list);
    if (limit && limit < frames.size()) frames.resize(limit);
    resume_at = std::min(resume_at, frames.size());
    fs::create_directories(log_dir);
    const fs::path straight_map = log_dir / "straight.placedb",
                   split_map = log_dir / "split.placedb";
    for (const auto& p : {straight_map, split_map}) placedb::storage::removeMap(p.string());
    std::vector<Row> straight, split;
    fmt::print(stderr, "straight run over {} frames\n", frames.size());
    run(straight_map.string(), frames, options, 0, frames.size(), straight);
    fmt::print(stderr, "split run: stop after {}, reopen, resume\n", resume_at);
    run(split_map.string(), frames, options, 0, resume_at, split);
    run(split_map.string(), frames, options, resume_at, frames.size(), split);
    writeLog(log_dir / "straight.csv", straight);
    writeLog(log_dir / "split.csv", split);

    std::size_t differ = 0;
    double worst = 0;
    for (std::size_t i = 0; i < frames.size(); ++i) {
      const Row &a = straight[i], &b = split[i];
      worst = std::max(worst, std::abs(a.posterior - b.posterior));
      if (a.candidates != b.candidates || a.accepted != b.accepted ||
          std::abs(a.score - b.score) > 1e-6)
        ++differ;
    }
    fmt::print("sequence {} ({} frames), settings: {}\n", list.string(), frames.size(),
               settings.empty() ? "defaults" : fmt::format("{}", fmt::join(settings, " ")));
    fmt::print("resumed at frame {}: {} frames differ, max posterior difference {:.3g}\n",
               resume_at, differ, worst);
    fmt::print("logs: {} and {}\n", (log_dir / "straight.csv").string(),
               (log_dir / "split.csv").string());
    printStages("time per stage, straight run", straight);
    return differ == 0 ? 0 : 1;
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 1;
  }
}
