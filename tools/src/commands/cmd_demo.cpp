#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "commands/commands.h"
#include "commands/mapping_run.h"
#include "placedb/storage/map_files.h"
#include "report/evaluation_run.h"
#include "synthetic/synthetic_sequence.h"

namespace placedb::cli {
namespace {

namespace fs = std::filesystem;

struct DemoRequest {
  std::string out = "demo-output";
  int frames = 300;
  std::uint64_t seed = 1;
  SettingsInput settings;
};

// How to call this very binary so that the hints run as printed: `placedb` when PATH finds it,
// else its path (relative to the current folder when it lies below it, e.g. build/tools/placedb).
std::string selfCommand() {
  std::error_code ec;
  const fs::path self = fs::canonical("/proc/self/exe", ec);
  if (ec) return "placedb";
  if (const char* path = std::getenv("PATH")) {
    std::stringstream folders(path);
    for (std::string folder; std::getline(folders, folder, ':');)
      if (!folder.empty() && fs::equivalent(fs::path(folder) / "placedb", self, ec))
        return "placedb";
  }
  const fs::path below = self.lexically_relative(fs::current_path(ec));
  if (ec || below.empty() || *below.begin() == "..") return self.string();
  return below.has_parent_path() ? below.string() : "./" + below.string();
}

// Word-wrapped, every line indented.
std::string wrap(const std::string& text, int indent, int width) {
  std::string out, line;
  std::size_t start = 0;
  while (start < text.size()) {
    std::size_t end = text.find(' ', start);
    if (end == std::string::npos) end = text.size();
    std::string word = text.substr(start, end - start);
    start = end + 1;
    if (!line.empty() && static_cast<int>(line.size() + word.size()) + 1 + indent > width) {
      out += std::string(static_cast<std::size_t>(indent), ' ') + line + "\n";
      line.clear();
    }
    line += (line.empty() ? "" : " ") + word;
  }
  if (!line.empty()) out += std::string(static_cast<std::size_t>(indent), ' ') + line + "\n";
  return out;
}

std::string percent(const std::optional<double>& value) {
  return value ? fmt::format("{:.2f}%", *value) : "undefined";
}

std::string explanation(const DemoRequest& request, const synthetic::SyntheticSequence& sequence,
                        const MappingSummary& mapped, const EvalFigures& exact,
                        const EvalFigures& near, const std::vector<WrittenPlot>& plots) {
  const fs::path out(request.out);
  std::string text = fmt::format(
      "\nWhat happened\n"
      "  A virtual camera drove {} frames through a synthetic town, driving some streets twice.\n"
      "  {} of those frames revisit a place seen before: the ground truth ({}).\n"
      "  placedb mapped them into {} ({:.1f} s, {:.1f} frames/s):\n"
      "  {} new locations, {} loop closures accepted. Every frame has a row in {}.\n\n"
      "The scores (definitions of score_loops.py, also `placedb eval`)\n"
      "  recall at 100% precision: {:.2f}% (within 10 frames: {:.2f}%)\n"
      "      the share of revisiting frames recognised with a score above every wrong guess:\n"
      "      how much the detector finds before it makes its first mistake.\n"
      "  accepted closures: {} right, {} wrong; precision {}, recall {}\n"
      "      what the engine itself declared with its threshold (t_loop).\n"
      "  time per frame: mean {:.1f} ms, p99 {:.1f} ms\n\n"
      "The figures ({})\n",
      sequence.size(), sequence.revisitingFrames(), (out / "sequence" / "gt_pairs.txt").string(),
      (out / "demo.placedb").string(), mapped.seconds,
      mapped.seconds > 0 ? static_cast<double>(mapped.processed) / mapped.seconds : 0.0,
      mapped.locations_created, mapped.loop_closures, (out / "run.csv").string(),
      exact.recall_at_100_precision, near.recall_at_100_precision, exact.accepted_true,
      exact.accepted_false, percent(exact.accepted_precision), percent(exact.accepted_recall),
      exact.time_ms_mean.value_or(0), exact.time_ms_p99.value_or(0), (out / "plots").string());
  for (const auto& plot : plots) text += fmt::format("  {}\n{}", plot.file, wrap(plot.what, 6, 92));
  text += fmt::format(
      "\nNext\n"
      "  what the map holds:               {5} info {0}\n"
      "  where was this image taken?:      {5} query {0} {1}\n"
      "  a second pass, a second session:  {5} map {0} {2}\n"
      "  the scores with a 10-frame window: {5} eval {3} {4} --window 10\n",
      (out / "demo.placedb").string(), (out / "sequence" / "images" / "000010.png").string(),
      (out / "sequence" / "frames.txt").string(), (out / "run.csv").string(),
      (out / "sequence" / "gt_pairs.txt").string(), selfCommand());
  std::error_code ec;
  if (selfCommand() != "placedb")
    text += fmt::format(
        "  (placedb is not on PATH: `export PATH=\"{}:$PATH\"` lets you call it as placedb)\n",
        fs::canonical("/proc/self/exe", ec).parent_path().string());
  return text;
}

int runDemo(const DemoRequest& request) {
  const fs::path out(request.out);
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec)
    throw Error(ErrorCode::kIo, fmt::format("cannot create {}: {}", request.out, ec.message()));
  // The demo starts afresh each time: only the files it made itself are replaced.
  storage::removeMap((out / "demo.placedb").string());
  fs::remove(out / "run.csv", ec);
  fs::remove_all(out / "plots", ec);

  synthetic::SyntheticOptions options;
  options.frames = request.frames;
  options.seed = request.seed;
  synthetic::SyntheticSequence sequence(options);
  std::fputs(fmt::format("placedb: rendering {} synthetic frames into {}\n", sequence.size(),
                         (out / "sequence").string())
                 .c_str(),
             stderr);
  synthetic::writeSequence(sequence, out / "sequence");

  MappingRequest mapping;
  mapping.map_path = (out / "demo.placedb").string();
  mapping.source = (out / "sequence" / "frames.txt").string();
  mapping.log_path = (out / "run.csv").string();
  mapping.settings = request.settings;
  MappingSummary mapped = runMapping(mapping);

  EvalRequest eval;
  eval.log = out / "run.csv";
  eval.gt = out / "sequence" / "gt_pairs.txt";
  eval.plots_dir = out / "plots";
  eval.map_path = mapping.map_path;
  EvalOutcome exact = runEvaluation(eval);
  eval.window = 10;
  eval.plots_dir.clear();
  EvalOutcome near = runEvaluation(eval);

  std::fputs(figuresText(exact.evaluation.figures).c_str(), stdout);
  std::fputs(explanation(request, sequence, mapped, exact.evaluation.figures,
                         near.evaluation.figures, exact.plots)
                 .c_str(),
             stdout);
  return 0;
}

}  // namespace

Command addDemoCommand(CLI::App& parent) {
  auto request = std::make_shared<DemoRequest>();
  CLI::App* app = parent.add_subcommand("demo", "Map, score and plot a synthetic tour");
  app->footer(
      "Needs no outside data: renders a synthetic camera tour with known loops, maps it, scores\n"
      "the run against the ground truth and draws its figures, then explains each number and\n"
      "figure. Writes DIR/sequence/ (images, frames.txt, gt_pairs.txt), DIR/demo.placedb,\n"
      "DIR/run.csv and DIR/plots/. Running it again starts afresh.\n\n"
      "Examples:\n"
      "  placedb demo\n"
      "  placedb demo --out /tmp/demo --frames 600 --set t_loop=0.2");
  app->add_option("--out", request->out, "output folder")->capture_default_str();
  app->add_option("--frames", request->frames, "frames in the tour")
      ->capture_default_str()
      ->check(CLI::Range(20, 100000));
  app->add_option("--seed", request->seed, "a different town and route")->capture_default_str();
  addSettingsOptions(*app, request->settings);
  return {app, [request]() { return runDemo(*request); }};
}

}  // namespace placedb::cli
