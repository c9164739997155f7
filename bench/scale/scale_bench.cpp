// Scale benchmark: maps N frames of the "scale" synthetic profile and reports, per window of
// frames, per-frame time p50/p99, peak and current RSS, file size per location, the time to
// reopen and resume the map (it is closed and reopened at every window end, which also exercises
// resume on a growing long-term memory), the localisation query time, and the loop closures
// accepted against the exact ground truth.
//
// Usage: kUsage below (--help prints it).
//
// --closures writes one row per accepted closure with how the query's view relates to the
// hypothesis frame that best matches it (footprint IoU, shared ground, heading, gap), so a
// closure the ground truth calls false can be checked frame by frame; --frame-times writes every
// frame's stage times, tier moves and what it read from the disk rather than the page cache, so
// the frames behind a window's p99 can be told apart from the rest; --show writes frames Q and R
// of the same sequence side by side, then R warped into Q's view, to look at one.
//
// Rows are printed as each window ends, so a run stopped early still leaves its figures.
#include <fcntl.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <malloc.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <tuple>
#include <vector>

#include "placedb/map.h"
#include "placedb/storage/map_files.h"
#include "placedb/storage/map_store.h"
#include "synthetic/ground_truth.h"
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
  bool query_only = false;   // query an existing map made with the same --frames, then stop
  int mapped = 0;            // --query-only: frames the map holds (0: --frames)
  int remap_from = -1;       // --remap: the first frame to map again (-1: no --remap)
  int remap_count = 0;       // --remap: how many
  bool cold = false;         // --remap: the map's pages leave the OS page cache first
  int width = 320, height = 240;
  std::uint64_t seed = 1;
  fs::path map = fs::temp_directory_path() / "placedb-scale-bench.placedb";
  fs::path closures;     // CSV of accepted closures, when set
  fs::path frame_times;  // CSV of every frame's stage times, when set
  bool help = false;
  int show_q = -1, show_r = -1;
  fs::path show_png;
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

// One frame through Map::process: its result, its time and what it read from the disk, both
// taken around the call alone.
struct TimedFrame {
  placedb::FrameResult result;
  double ms = 0;
  std::uint64_t disk_bytes = 0;
};

// One window's stage times.
struct StageSums {
  std::vector<placedb::StageTimes> frames;
  std::vector<double> memory, storage;
  std::size_t retrieved = 0, by_search = 0;  // tier moves, which grow with revisits
  std::uint64_t disk_bytes = 0;              // read from storage, not from the page cache
  void add(const TimedFrame& frame) {
    const placedb::FrameResult& r = frame.result;
    disk_bytes += frame.disk_bytes;
    frames.push_back(r.times);
    memory.push_back(r.times.memory);
    storage.push_back(r.times.storage);
    retrieved += r.retrieved;
    by_search += r.retrieved_by_search;
  }
  double perFrame(std::size_t count) const {
    return frames.empty() ? 0.0 : double(count) / double(frames.size());
  }
  double mean(double placedb::StageTimes::*stage) const {
    double sum = 0;
    for (const auto& t : frames) sum += t.*stage;
    return frames.empty() ? 0.0 : sum / double(frames.size());
  }
};

// What this thread has had read from storage rather than served by the page cache
// (/proc/thread-self/io, read_bytes): a frame that waits on the disk for its long-term memory
// shows here, which its stage times cannot tell from slower work. 0 where the kernel does not
// account I/O.
class DiskReads {
 public:
  DiskReads() : fd_(::open("/proc/thread-self/io", O_RDONLY | O_CLOEXEC)) {}
  ~DiskReads() {
    if (fd_ >= 0) ::close(fd_);
  }
  DiskReads(const DiskReads&) = delete;
  DiskReads& operator=(const DiskReads&) = delete;

  std::uint64_t bytes() const {
    char text[512];
    const ssize_t n = fd_ >= 0 ? ::pread(fd_, text, sizeof text - 1, 0) : -1;
    if (n <= 0) return 0;
    text[n] = '\0';
    static constexpr char kField[] = "\nread_bytes: ";
    const char* field = std::strstr(text, kField);
    return field ? std::strtoull(field + sizeof kField - 1, nullptr, 10) : 0;
  }

 private:
  int fd_;
};

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

// The current resident set once the heap has handed its free pages back (malloc_trim): what the
// writer holds live. The reader this benchmark opens beside it for the queries frees its memory
// on close, but the heap keeps much of it, and curRSS swings by 100-200 MB with that.
double liveRssMiB() {
  malloc_trim(0);
  return currentRssMiB();
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

constexpr const char* kUsage = R"(usage:
  placedb_scale_bench [--frames N] [--wm-max M] [--window W] [--map PATH] [--seed S]
                      [--width W] [--height H] [--queries Q] [--set key=value]...
                      [--closures CSV] [--frame-times CSV]
  placedb_scale_bench --reopen-only MAP [--wm-max M]
  placedb_scale_bench --frames N [--seed S] [--width W] [--height H] --show Q R PNG
  placedb_scale_bench --frames N [--width W] [--height H] [--queries Q] [--mapped M]
                      --query-only MAP
  placedb_scale_bench --frames N [--seed S] [--width W] [--height H] [--wm-max M]
                      [--frame-times CSV] [--cold] --remap MAP FIRST COUNT

Maps N synthetic frames (default 100000 at 320x240, wm_max 1500, windows of 5000) and prints
one row per window: frame time p50/p99/max, tiers, RSS, file bytes per location, reopen and
query times, loop closures against the exact ground truth, and per-stage means.
  --closures CSV     one row per accepted closure, with how its two views relate
  --frame-times CSV  one row per frame: its time, stage times, tier moves and the KB it read
                     from the disk (pages the page cache no longer held)
  --remap MAP FIRST COUNT
                     a new session on MAP (made by this bench with the same --frames, size and
                     seed; it is changed) maps frames FIRST.. again and prints one row: what a
                     frame costs on a map that size, without making the map again. With another
                     --seed the frames are places MAP never saw (bench/scale/same_frames.py)
  --cold             with --remap: MAP's pages leave the OS page cache first (fsync, then
                     posix_fadvise DONTNEED), as those of a map larger than RAM, or idle
                     for long, have: what the frames read of old places comes from the disk
  --set key=value    any engine setting (as placedb's --set); wm_max comes from --wm-max
See bench/scale/README.md for the columns and the runs measured so far.
)";

Flags parseFlags(int argc, char** argv) {
  Flags f;
  for (int i = 1; i < argc; ++i) {
    std::string flag = argv[i];
    if (flag == "--help" || flag == "-h") {
      f.help = true;
      return f;
    }
    if (flag == "--reopen-only" || flag == "--query-only") {
      if (i + 1 >= argc) throw std::invalid_argument(flag + " needs a map");
      f.map = argv[++i];
      (flag == "--reopen-only" ? f.reopen_only : f.query_only) = true;
      continue;
    }
    if (flag == "--remap") {
      if (i + 3 >= argc) throw std::invalid_argument(flag + " needs MAP FIRST COUNT");
      f.map = argv[i + 1];
      f.remap_from = std::stoi(argv[i + 2]);
      f.remap_count = std::stoi(argv[i + 3]);
      if (f.remap_from < 0 || f.remap_count < 1)
        throw std::invalid_argument("--remap needs FIRST >= 0 and COUNT >= 1");
      i += 3;
      continue;
    }
    if (flag == "--cold") {
      f.cold = true;
      continue;
    }
    if (flag == "--show") {
      if (i + 3 >= argc) throw std::invalid_argument(flag + " needs Q R PNG");
      f.show_q = std::stoi(argv[i + 1]);
      f.show_r = std::stoi(argv[i + 2]);
      f.show_png = argv[i + 3];
      i += 3;
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
    else if (flag == "--mapped")
      f.mapped = std::stoi(value);
    else if (flag == "--width")
      f.width = std::stoi(value);
    else if (flag == "--height")
      f.height = std::stoi(value);
    else if (flag == "--seed")
      f.seed = std::stoull(value);
    else if (flag == "--map")
      f.map = value;
    else if (flag == "--closures")
      f.closures = value;
    else if (flag == "--frame-times")
      f.frame_times = value;
    else if (flag == "--set")
      f.settings[value.substr(0, value.find('='))] = value.substr(value.find('=') + 1);
    else
      throw std::invalid_argument("unknown flag " + flag + " (--help lists them)");
  }
  if (f.frames < 1 || f.window < 1)
    throw std::invalid_argument("--frames and --window must be >= 1");
  return f;
}

// The hypothesis frame that best explains an accepted closure of frame q: one the ground truth
// lists if there is one, else the one sharing the most ground with q. The list and the judge of
// a closure are one rule (isRevisit()), so "listed" and "same" agree; both columns stay so that
// rows compare with runs made before they did.
struct ClosureView {
  int r = -1;
  placedb::synthetic::ViewRelation relation;
  bool listed = false;  // (q, r) is in the ground truth's revisit list
  bool same = false;    // isRevisit() of q and r: the closure is right
};

placedb::synthetic::GroundTruthSettings truthSettings(
    const placedb::synthetic::SyntheticOptions& o) {
  placedb::synthetic::GroundTruthSettings settings;
  settings.min_gap = o.min_revisit_gap;
  settings.min_shared = o.gt_min_shared;
  return settings;
}

ClosureView bestView(const placedb::synthetic::SyntheticSequence& seq, int q,
                     const placedb::FrameResult& result) {
  const auto settings = truthSettings(seq.options());
  const auto truth = seq.revisitsOf(q);
  ClosureView best;
  for (const auto& f : result.hypothesis.frames) {
    const int r = static_cast<int>(f.source_index);
    if (r < 0 || r >= seq.size()) continue;
    ClosureView v;
    v.r = r;
    v.relation = placedb::synthetic::relateViews(q, seq.pose(q), r, seq.pose(r), seq.camera());
    v.listed = std::binary_search(truth.begin(), truth.end(), r);
    v.same = placedb::synthetic::isRevisit(v.relation, settings);
    if (best.r < 0 || std::make_tuple(v.listed, v.same, v.relation.shared) >
                          std::make_tuple(best.listed, best.same, best.relation.shared))
      best = v;
  }
  return best;
}

void writeClosure(std::FILE* out, int q, const placedb::FrameResult& result, const ClosureView& v) {
  std::vector<std::int64_t> frames;
  for (const auto& f : result.hypothesis.frames) frames.push_back(f.source_index);
  fmt::print(out, "{},{},{},{},{},{},{:.3f},{:.3f},{:.1f},{},{},{},{},{:.1f},{:.3f}\n", q,
             result.hypothesis.location_id, frames.size(), fmt::join(frames, ";"), v.r,
             v.relation.gap, v.relation.iou, v.relation.shared, v.relation.heading * 180 / CV_PI,
             int(v.listed), int(v.same), result.hypothesis.inliers, result.hypothesis.matches,
             result.hypothesis.log10_nfa, result.hypothesis.posterior);
}

struct QueryFigures {
  double p50 = 0, max = 0;
  int found = 0, asked = 0;
};

// A query's answer frame r is right for frame i when it lies within 2 frames of i or the ground
// truth pairs the two as a revisit (either way round): a revisited place is held by the
// locations of each of its visits, and any of them answers where the camera is.
bool coversFrame(const placedb::synthetic::SyntheticSequence& seq, int i, int r) {
  if (std::abs(r - i) <= 2) return true;
  if (r < 0 || r >= seq.size()) return false;
  const int q = std::max(i, r), older = std::min(i, r);
  return placedb::synthetic::isRevisit(
      placedb::synthetic::relateViews(q, seq.pose(q), older, seq.pose(older), seq.camera()),
      truthSettings(seq.options()));
}

// Localisation on the map as it stands: a read-only Map beside the writer, querying frames that
// were mapped (spread over the whole run), counting those whose best match covers the frame
// (coversFrame()).
QueryFigures measureQueries(const Flags& flags, const placedb::Options& options,
                            const placedb::synthetic::SyntheticSequence& seq, int mapped,
                            bool verbose = false) {
  QueryFigures out;
  if (flags.queries <= 0) return out;
  auto reader = placedb::Map::open(flags.map.string(), options, placedb::Map::Mode::kLocalisation);
  std::vector<double> times;
  for (int k = 0; k < flags.queries; ++k) {
    int i = static_cast<int>((static_cast<long long>(mapped) * (2 * k + 1)) / (2 * flags.queries));
    const cv::Mat image = seq.render(i);  // rendering is not the query's time
    auto start = Clock::now();
    auto result = reader->query(image, 1);
    times.push_back(msBetween(start, Clock::now()));
    ++out.asked;
    bool found = false;
    if (!result.matches.empty())
      for (const auto& f : result.matches[0].frames)
        if (coversFrame(seq, i, static_cast<int>(f.source_index))) found = true;
    out.found += found;
    if (verbose) {
      std::string best = "none";
      if (!result.matches.empty()) {
        const auto& m = result.matches[0];
        best = fmt::format("location {} ({}, {} inliers), frames", m.location_id,
                           m.tier == placedb::Tier::kLtm ? "ltm" : "ram", m.inliers);
        for (const auto& f : m.frames) best += " " + std::to_string(f.source_index);
      }
      fmt::print("frame {:>6}: {:>7.1f} ms, {} searched, {} checked, {}: {}{}\n", i, times.back(),
                 result.searched, result.checked, placedb::toString(result.verdict), best,
                 found ? "" : "  (not found)");
    }
  }
  out.p50 = percentile(times, 50);
  out.max = *std::max_element(times.begin(), times.end());
  return out;
}

// Rendering, and the reopen and queries at a window's end, fall outside both measures.
TimedFrame processFrame(placedb::Map& map, const placedb::synthetic::SyntheticSequence& seq, int i,
                        const DiskReads& disk) {
  cv::Mat image = seq.render(i);
  TimedFrame frame;
  const std::uint64_t disk_before = disk.bytes();
  auto start = Clock::now();
  frame.result = map.process(image, i, "frame " + std::to_string(i));
  frame.ms = msBetween(start, Clock::now());
  frame.disk_bytes = disk.bytes() - disk_before;
  return frame;
}

void writeFrameTimes(std::FILE* out, int i, const TimedFrame& frame) {
  const placedb::FrameResult& r = frame.result;
  const placedb::StageTimes& t = r.times;
  fmt::print(out, "{},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{},{},{},{},{}\n", i,
             frame.ms, t.features, t.quantisation, t.likelihood, t.filter, t.verification, t.memory,
             t.storage, r.retrieved, r.retrieved_by_search, r.transferred,
             int(r.hypothesis.accepted), frame.disk_bytes / 1024);
}

std::FILE* openFrameTimes(const Flags& flags) {
  if (flags.frame_times.empty()) return nullptr;
  std::FILE* out = std::fopen(flags.frame_times.c_str(), "w");
  if (!out) throw std::runtime_error("cannot write " + flags.frame_times.string());
  fmt::print(out,
             "frame,ms,features,quantisation,likelihood,filter,verification,memory,storage,"
             "retrieved,retrieved_by_search,transferred,accepted,disk_kb\n");
  return out;
}

// --cold: every page of the map's files leaves the page cache (written back first: the kernel
// keeps dirty pages).
void dropFromPageCache(const fs::path& map) {
  for (const std::string& file : placedb::storage::mapFiles(map.string())) {
    const int fd = ::open(file.c_str(), O_RDONLY);
    if (fd < 0 && errno == ENOENT) continue;  // a side file the map does not have now
    if (fd < 0) throw std::runtime_error(file + ": " + std::strerror(errno));
    ::fsync(fd);
    const int error = ::posix_fadvise(fd, 0, 0, POSIX_FADV_DONTNEED);
    ::close(fd);
    if (error != 0) throw std::runtime_error(file + ": posix_fadvise: " + std::strerror(error));
  }
}

// --remap: frames of the sequence mapped again, in a new session, on a map this bench made.
int remap(const Flags& flags, const placedb::Options& options,
          const placedb::synthetic::SyntheticSequence& seq) {
  if (!fs::exists(flags.map)) throw std::runtime_error(flags.map.string() + ": no such map");
  const int last = std::min(seq.size(), flags.remap_from + flags.remap_count);
  if (flags.remap_from >= last)
    throw std::invalid_argument("--remap: frame " + std::to_string(flags.remap_from) +
                                " is past the sequence's " + std::to_string(seq.size()));
  std::FILE* frame_times = openFrameTimes(flags);
  if (flags.cold) dropFromPageCache(flags.map);
  auto map = placedb::Map::open(flags.map.string(), options);
  map->beginSession("scale bench remap");
  std::vector<double> times;
  StageSums stages;
  int accepted = 0;
  const DiskReads disk;
  for (int i = flags.remap_from; i < last; ++i) {
    const TimedFrame frame = processFrame(*map, seq, i, disk);
    times.push_back(frame.ms);
    stages.add(frame);
    accepted += frame.result.hypothesis.accepted;
    if (frame_times) writeFrameTimes(frame_times, i, frame);
  }
  map->close();
  if (frame_times) std::fclose(frame_times);
  fmt::print(
      "{}: frames {}-{} again: p50 {:.2f} ms, p99 {:.2f} ms | feat {:.2f} quant {:.2f} filt {:.2f} "
      "verif {:.2f} mem {:.2f} stor {:.2f} (ms), mem p99 {:.2f}, retr {:.2f} srch {:.2f} a "
      "frame; {} closures; {:.1f} MB read from disk\n",
      flags.map.string(), flags.remap_from, last - 1, percentile(times, 50), percentile(times, 99),
      stages.mean(&placedb::StageTimes::features), stages.mean(&placedb::StageTimes::quantisation),
      stages.mean(&placedb::StageTimes::filter), stages.mean(&placedb::StageTimes::verification),
      stages.mean(&placedb::StageTimes::memory), stages.mean(&placedb::StageTimes::storage),
      percentile(stages.memory, 99), stages.perFrame(stages.retrieved),
      stages.perFrame(stages.by_search), accepted, stages.disk_bytes / 1e6);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    Flags flags = parseFlags(argc, argv);
    if (flags.help) {
      fmt::print("{}", kUsage);
      return 0;
    }
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
    if (flags.query_only) {
      const QueryFigures q =
          measureQueries(flags, options, seq, flags.mapped > 0 ? flags.mapped : seq.size(), true);
      fmt::print("{}: {} of {} found, query p50 {:.1f} ms, max {:.1f} ms\n", flags.map.string(),
                 q.found, q.asked, q.p50, q.max);
      return 0;
    }
    if (flags.remap_from >= 0) return remap(flags, options, seq);
    if (!flags.show_png.empty()) {
      // The third panel is r drawn in q's camera with the exact homography of the ground: where
      // it lines up with the first, the two frames show the same ground.
      const cv::Mat q_image = seq.render(flags.show_q), r_image = seq.render(flags.show_r);
      cv::Mat r_in_q;
      cv::warpPerspective(r_image, r_in_q, cv::Mat(seq.homography(flags.show_r, flags.show_q)),
                          q_image.size());
      cv::Mat panels;
      cv::hconcat(std::vector<cv::Mat>{q_image, r_image, r_in_q}, panels);
      cv::imwrite(flags.show_png.string(), panels);
      auto rel = placedb::synthetic::relateViews(flags.show_q, seq.pose(flags.show_q), flags.show_r,
                                                 seq.pose(flags.show_r), seq.camera());
      fmt::print("{}: frames {} | {}, IoU {:.3f}, shared {:.3f}, heading {:.1f} deg, gap {}\n",
                 flags.show_png.string(), flags.show_q, flags.show_r, rel.iou, rel.shared,
                 rel.heading * 180 / CV_PI, rel.gap);
      return 0;
    }
    std::FILE* closures = nullptr;
    if (!flags.closures.empty()) {
      closures = std::fopen(flags.closures.c_str(), "w");
      if (!closures) throw std::runtime_error("cannot write " + flags.closures.string());
      fmt::print(closures,
                 "q,location,n_frames,frames,r,gap,iou,shared,heading_deg,listed,same,inliers,"
                 "matches,log10_nfa,posterior\n");
    }
    std::FILE* frame_times = openFrameTimes(flags);
    fmt::print(
        "scale profile: {} frames {}x{}, seed {}, {} revisiting frames (first at {}), "
        "planned in {:.1f} s\n",
        seq.size(), flags.width, flags.height, flags.seed, seq.revisitingFrames(),
        seq.firstRevisit(), msBetween(planned, Clock::now()) / 1000);
    fmt::print("settings: wm_max={} (others default{}), map {}\n", flags.wm_max,
               flags.settings.empty() ? "" : " except --set", flags.map.string());
    fmt::print(
        "{:>7} {:>8} {:>8} {:>8} {:>6} {:>7} {:>8} {:>8} {:>8} {:>9} {:>9} {:>9} {:>8} {:>6} {:>6} "
        "{:>6} | {:>5} {:>5} {:>5} {:>5} {:>5} {:>5} {:>7} {:>7} {:>5} {:>5} {:>7}\n",
        "frames", "p50 ms", "p99 ms", "max ms", "wm", "ltm", "peakRSS", "curRSS", "liveRSS",
        "B/locatn", "reopen ms", "query ms", "q found", "loops", "true", "listed", "feat", "quant",
        "filt", "verif", "mem", "stor", "mem p99", "stor p99", "retr", "srch", "disk MB");
    std::fflush(stdout);

    removeMap(flags.map);
    auto map = placedb::Map::open(flags.map.string(), options);
    map->beginSession("synthetic scale");
    std::vector<double> window_times;
    // Per stage, to find what grows with the map: means, and the p99 of the two stages that
    // touch long-term memory.
    StageSums stages;
    int accepted = 0, accepted_true = 0, accepted_listed = 0;
    std::int64_t locations = 0;
    const DiskReads disk;
    for (int i = 0; i < seq.size(); ++i) {
      const TimedFrame frame = processFrame(*map, seq, i, disk);
      const placedb::FrameResult& r = frame.result;
      window_times.push_back(frame.ms);
      stages.add(frame);
      if (frame_times) writeFrameTimes(frame_times, i, frame);
      locations = std::max(locations, r.location_id);
      if (r.hypothesis.accepted) {
        ++accepted;
        const ClosureView v = bestView(seq, i, r);
        accepted_true += v.same;
        accepted_listed += v.listed;
        if (closures) writeClosure(closures, i, r, v);
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
      const double current_rss = currentRssMiB();
      fmt::print(
          "{:>7} {:>8.2f} {:>8.2f} {:>8.1f} {:>6} {:>7} {:>7.0f}M {:>7.0f}M {:>7.0f}M {:>9.0f} "
          "{:>9.1f} {:>9.1f} {:>5}/{:<2} {:>6} {:>6} {:>6} | {:>5.2f} {:>5.2f} {:>5.2f} {:>5.2f} "
          "{:>5.2f} {:>5.2f} {:>7.2f} {:>7.2f} {:>5.2f} {:>5.2f} {:>7.1f}\n",
          i + 1, percentile(window_times, 50), percentile(window_times, 99),
          *std::max_element(window_times.begin(), window_times.end()), r.wm_size, ltm, peakRssMiB(),
          current_rss, liveRssMiB(),
          double(mapBytes(flags.map)) / std::max<std::int64_t>(1, locations), reopen_ms, q.p50,
          q.found, q.asked, accepted, accepted_true, accepted_listed,
          stages.mean(&placedb::StageTimes::features),
          stages.mean(&placedb::StageTimes::quantisation),
          stages.mean(&placedb::StageTimes::filter),
          stages.mean(&placedb::StageTimes::verification),
          stages.mean(&placedb::StageTimes::memory), stages.mean(&placedb::StageTimes::storage),
          percentile(stages.memory, 99), percentile(stages.storage, 99),
          stages.perFrame(stages.retrieved), stages.perFrame(stages.by_search),
          stages.disk_bytes / 1e6);
      std::fflush(stdout);
      window_times.clear();
      stages = StageSums();
      if (closures) std::fflush(closures);
    }
    map->close();
    if (closures) std::fclose(closures);
    if (frame_times) std::fclose(frame_times);
    fmt::print(
        "done: {} frames, {} locations, map {:.1f} MiB; accepted loop closures {} "
        "({} true, precision {:.3f}; {} in the revisit list, {:.3f})\n",
        seq.size(), locations, mapBytes(flags.map) / 1048576.0, accepted, accepted_true,
        accepted ? double(accepted_true) / accepted : 1.0, accepted_listed,
        accepted ? double(accepted_listed) / accepted : 1.0);
    return 0;
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 1;
  }
}
