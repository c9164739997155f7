#include <fmt/format.h>

#include <cmath>
#include <cstdio>

#include "commands/commands.h"
#include "exit_codes.h"
#include "frame_log.h"
#include "map_argument.h"
#include "report/evaluation_run.h"

namespace placedb::cli {

Command addEvalCommand(CLI::App& parent) {
  auto request = std::make_shared<EvalRequest>();
  auto json = std::make_shared<bool>(false);
  auto session = std::make_shared<std::int64_t>(0);
  CLI::App* app = parent.add_subcommand("eval", "Score a per-frame log against ground truth");
  app->footer(
      "Score a per-frame log (written by `placedb map --log`) against ground-truth pairs, with\n"
      "the definitions of the reference scorer score_loops.py: recall at 100% precision (R@100P),\n"
      "precision and recall of the accepted closures, time per frame. Without --json the output\n"
      "is line for line what score_loops.py prints (nan and None included: stderr says why).\n\n"
      "GT holds lines `q r` (0-based, q > r: frame q revisits frame r); '#' starts a comment.\n"
      "A hypothesis is right when one of its candidate frames is within W frames of a\n"
      "ground-truth reference.\n\n"
      "Examples:\n"
      "  placedb eval run.csv gt_pairs.txt\n"
      "  placedb eval run.csv gt_pairs.txt --window 10 --json\n"
      "  placedb eval run.csv gt_pairs.txt --plots figures/ --map run.placedb");
  app->add_option("LOG", request->log, "per-frame CSV log")->required();
  app->add_option("GT", request->gt, "ground-truth pairs file")->required();
  app->add_option("--window,-w", request->window, "tolerance in frames (0: exact)")
      ->check(CLI::NonNegativeNumber);
  app->add_option("--plots", request->plots_dir,
                  "write PNG figures (precision-recall, score, vocabulary, quantisation error, "
                  "WM size, time per frame and by stage, loop matrix) into this folder");
  app->add_option("--map", request->map_path,
                  "take the series the log lacks (vocabulary, WM, times) from this map (a file "
                  "or a postgresql:// URI)")
      ->transform(mapArgument());
  app->add_option("--session", *session, "session of --map the log belongs to (default: last)");
  app->add_flag("--json", *json, "one JSON object, as score_loops.py --json");
  return {app, [request, json, session, app]() {
            if (app->count("--session")) request->session = *session;
            EvalOutcome outcome = runEvaluation(*request);
            const EvalFigures& figures = outcome.evaluation.figures;
            std::fputs((*json ? figuresJson(figures) : figuresText(figures)).c_str(), stdout);
            // The figures stay byte for byte the reference scorer's (nan, None); what they mean
            // goes to stderr, where no script comparing outputs reads it.
            if (std::isnan(figures.recall_at_100_precision))
              printNote(
                  "recall_at_100_precision is nan: the ground truth has no loop frame "
                  "among the log's frames");
            if (!figures.accepted_precision)
              printNote("accepted_precision is None: the run accepted no loop closure");
            if (!figures.accepted_recall)
              printNote("accepted_recall is None: the ground truth has no loop frame");
            if (!*json)
              for (const auto& plot : outcome.plots)
                std::fputs(
                    fmt::format("plot: {}\n", (request->plots_dir / plot.file).string()).c_str(),
                    stdout);
            return 0;
          }};
}

}  // namespace placedb::cli
