// Scale benchmark: maps N frames of the "scale" synthetic profile and reports, per window of
// frames, per-frame time p50/p99, peak and current RSS, file size per location, the time to
// reopen and resume the map (it is closed and reopened at every window end, which also exercises
// resume on a growing long-term memory), the localisation query time, and the loop closures
// accepted against the exact ground truth.
//
//   placedb_scale_bench [--frames N] [--wm-max M] [--window W] [--map PATH] [--seed S]
//                       [--width W] [--height H] [--queries Q] [--set key=value]...
//
// Rows are printed as each window ends, so a run stopped early still leaves its figures.
#include <fmt/format.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "placedb/map.h"
#include "placedb/storage/map_files.h"
#include "placedb/storage/map_store.h"
#include "synthetic/synthetic_sequence.h"

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

struct Flags {
  int frames = 100000;
  int wm_max = 1500;
  int window = 5000;
  int queries = 10;
  bool reopen_only = false;  // time Map::open + resumeSession on an existing map, then stop
  int width = 320, height = 240;
  std::uint64_t seed = 1;
  fs::path map = fs::temp_directory_path() / "placedb-scale-bench.placedb";
  std::map<std::string, std::string> settings;
};

double msBetween(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1,
                    static_cast<std::size_t>(std::lround(p / 100.0 * (v.size() - 1))))];
}

double peakRssMiB() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024.0;  // kilobytes on Linux
}

// Current resident set: peak RSS never goes down, so flatness shows better in this one.
double currentRssMiB() {
  std::ifstream statm("/proc/self/statm");
  long pages_total = 0, pages_resident = 0;
  statm >> pages_total >> pages_resident;
  return pages_resident * (sysconf(_SC_PAGESIZE) / 1024.0) / 1024.0;
}

std::uintmax_t mapBytes(const fs::path& map) {
  std::uintmax_t bytes = 0;
  for (const auto& file : {map.string(), placedb::storage::walFile(map.string())}) {
    std::error_code ec;
    auto size = fs::file_size(file, ec);
    if (!ec) bytes += size;
  }
  return bytes;
}

void removeMap(const fs::path& map) { placedb::storage::removeMap(map.string()); }

Flags parseFlags(int argc, char** argv) {
  Flags f;
  for (int i = 1; i < argc; ++i) {
    std::string flag = argv[i];
    if (flag == "--reopen-only") {
      if (i + 1 >= argc) throw std::invalid_argument(flag + " needs a map");
      f.map = argv[i + 1];
      f.reopen_only = true;
      ++i;
      continue;
    }
    if (i + 1 >= argc) throw std::invalid_argument(flag + " needs a value");
    std::string value = argv[++i];
    if (flag == "--frames")
      f.frames = std::stoi(value);
    else if (flag == "--wm-max")
      f.wm_max = std::stoi(value);
    else if (flag == "--window")
      f.window = std::stoi(value);
    else if (flag == "--queries")
      f.queries = std::stoi(value);
    else if (flag == "--width")
      f.width = std::stoi(value);
    else if (flag == "--height")
      f.height = std::stoi(value);
    else if (flag == "--seed")
      f.seed = std::stoull(value);
    else if (flag == "--map")
      f.map = value;
    else if (flag == "--set")
      f.settings[value.substr(0, value.find('='))] = value.substr(value.find('=') + 1);
    else
      throw std::invalid_argument("unknown flag " + flag);
  }
  if (f.frames < 1 || f.window < 1)
    throw std::invalid_argument("--frames and --window must be >= 1");
  return f;
}

// True when the accepted hypothesis covers a frame that q truly revisits.
bool acceptedIsTrue(const placedb::synthetic::SyntheticSequence& seq, int q,
                    const placedb::FrameResult& r) {
  auto truth = seq.revisitsOf(q);
  for (const auto& f : r.hypothesis.frames)
    if (std::binary_search(truth.begin(), truth.end(), static_cast<int>(f.source_index)))
      return true;
  return false;
}

struct QueryFigures {
  double p50 = 0, max = 0;
  int found = 0, asked = 0;
};

// Localisation on the map as it stands: a read-only Map beside the writer, querying frames that
// were mapped (spread over the whole run), counting those whose best match covers the frame.
QueryFigures measureQueries(const Flags& flags, const placedb::Options& options,
                            const placedb::synthetic::SyntheticSequence& seq, int mapped) {
  QueryFigures out;
  if (flags.queries <= 0) return out;
  auto reader = placedb::Map::open(flags.map.string(), options, placedb::Map::Mode::kLocalisation);
  std::vector<double> times;
  for (int k = 0; k < flags.queries; ++k) {
    int i = static_cast<int>((static_cast<long long>(mapped) * (2 * k + 1)) / (2 * flags.queries));
    auto start = Clock::now();
    auto result = reader->query(seq.render(i), 1);
    times.push_back(msBetween(start, Clock::now()));
    ++out.asked;
    if (!result.matches.empty())
      for (const auto& f : result.matches[0].frames)
        if (std::abs(f.source_index - i) <= 2) {
          ++out.found;
          break;
        }
  }
  out.p50 = percentile(times, 50);
  out.max = *std::max_element(times.begin(), times.end());
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    Flags flags = parseFlags(argc, argv);
    auto settings = flags.settings;
    settings["wm_max"] = std::to_string(flags.wm_max);
    placedb::Options options = placedb::Options::fromSettings(settings);
    if (flags.reopen_only) {
      auto start = Clock::now();
      auto map = placedb::Map::open(flags.map.string(), options);
      auto opened = Clock::now();
      map->resumeSession(map->lastSession()->id);
      fmt::print("{}: Map::open {:.1f} ms, resumeSession {:.1f} ms, peak RSS {:.0f} MiB\n",
                 flags.map.string(), msBetween(start, opened), msBetween(opened, Clock::now()),
                 peakRssMiB());
      return 0;
    }

    placedb::synthetic::SyntheticOptions synthetic;
    synthetic.profile = "scale";
    synthetic.frames = flags.frames;
    synthetic.seed = flags.seed;
    synthetic.width = flags.width;
    synthetic.height = flags.height;
    auto planned = Clock::now();
    placedb::synthetic::SyntheticSequence seq(synthetic);
    fmt::print(
        "scale profile: {} frames {}x{}, seed {}, {} revisiting frames (first at {}), "
        "planned in {:.1f} s\n",
        seq.size(), flags.width, flags.height, flags.seed, seq.revisitingFrames(),
        seq.firstRevisit(), msBetween(planned, Clock::now()) / 1000);
    fmt::print("settings: wm_max={} (others default{}), map {}\n", flags.wm_max,
               flags.settings.empty() ? "" : " except --set", flags.map.string());
    fmt::print(
        "{:>7} {:>8} {:>8} {:>8} {:>6} {:>7} {:>8} {:>8} {:>9} {:>9} {:>9} {:>8} {:>6} {:>6}\n",
        "frames", "p50 ms", "p99 ms", "max ms", "wm", "ltm", "peakRSS", "curRSS", "B/locatn",
        "reopen ms", "query ms", "q found", "loops", "true");
    std::fflush(stdout);

    removeMap(flags.map);
    auto map = placedb::Map::open(flags.map.string(), options);
    map->beginSession("synthetic scale");
    std::vector<double> window_times;
    int accepted = 0, accepted_true = 0;
    std::int64_t locations = 0;
    for (int i = 0; i < seq.size(); ++i) {
      cv::Mat image = seq.render(i);
      auto start = Clock::now();
      placedb::FrameResult r = map->process(image, i, "frame " + std::to_string(i));
      window_times.push_back(msBetween(start, Clock::now()));
      locations = std::max(locations, r.location_id);
      if (r.hypothesis.accepted) {
        ++accepted;
        accepted_true += acceptedIsTrue(seq, i, r);
      }
      const bool window_end = (i + 1) % flags.window == 0 || i + 1 == seq.size();
      if (!window_end) continue;

      // Reopen and resume: what a restarted mapper pays, whatever the long-term memory holds.
      map->close();
      map.reset();
      auto reopen_start = Clock::now();
      map = placedb::Map::open(flags.map.string(), options);
      map->resumeSession(map->lastSession()->id);
      double reopen_ms = msBetween(reopen_start, Clock::now());
      QueryFigures q = measureQueries(flags, options, seq, i + 1);
      std::int64_t ltm = locations - static_cast<std::int64_t>(r.wm_size + r.stm_size);
      fmt::print(
          "{:>7} {:>8.2f} {:>8.2f} {:>8.1f} {:>6} {:>7} {:>7.0f}M {:>7.0f}M {:>9.0f} "
          "{:>9.1f} {:>9.1f} {:>5}/{:<2} {:>6} {:>6}\n",
          i + 1, percentile(window_times, 50), percentile(window_times, 99),
          *std::max_element(window_times.begin(), window_times.end()), r.wm_size, ltm, peakRssMiB(),
          currentRssMiB(), double(mapBytes(flags.map)) / std::max<std::int64_t>(1, locations),
          reopen_ms, q.p50, q.found, q.asked, accepted, accepted_true);
      std::fflush(stdout);
      window_times.clear();
    }
    map->close();
    fmt::print(
        "done: {} frames, {} locations, map {:.1f} MiB; accepted loop closures {} "
        "({} true, precision {:.3f})\n",
        seq.size(), locations, mapBytes(flags.map) / 1048576.0, accepted, accepted_true,
        accepted ? double(accepted_true) / accepted : 1.0);
    return 0;
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 1;
  }
}
