#include <fmt/format.h>

#include <cstdio>
#include <memory>

#include "commands/commands.h"
#include "map_argument.h"
#include "report/report.h"

namespace placedb::cli {

Command addReportCommand(CLI::App& parent) {
  auto request = std::make_shared<ReportRequest>();
  auto session = std::make_shared<std::int64_t>(0);
  CLI::App* app =
      parent.add_subcommand("report", "Write one HTML page about a run: scores, figures, closures");
  app->footer(
      "Write DIR/index.html: one page that shows how a run went, to read in any browser or to\n"
      "send on its own (every picture is inside the file):\n"
      "  - the score table of `placedb eval` (R@100P, precision and recall of the accepted\n"
      "    closures, their right/wrong counts, time per frame);\n"
      "  - the figures of `placedb eval --plots`: precision-recall with the R@100P point and the\n"
      "    engine's own operating point, score per frame with right, wrong and missed loops, the\n"
      "    loop matrix, time per frame by stage, vocabulary and WM size;\n"
      "  - every accepted closure as two thumbnails, the frame beside the frame it was matched\n"
      "    with: the wrong ones first (up to --max-wrong), then a sample of the right ones (up\n"
      "    to --max-right, spread over the run);\n"
      "  - the closures to places of other sessions of the map, which one sequence's ground\n"
      "    truth cannot judge.\n"
      "Without GT the page shows the run (frames, closures, time), the figures that need no\n"
      "ground truth, and the closures without a verdict (a sample of up to --max-wrong +\n"
      "--max-right).\n\n"
      "MAP is the map LOG was written with (`placedb map MAP SOURCE --log LOG`); the thumbnails\n"
      "are read from the image paths the map stores, or from the video or bag at the frame's\n"
      "index, so the sources must still be there (a missing one is a grey box naming the\n"
      "file, not an error). GT holds `q r` lines as for\n"
      "`placedb eval`. DIR is made if needed; an index.html in it is replaced, nothing else is\n"
      "touched. A refused report writes nothing.\n\n"
      "Exit status: 0 written; 2 a bad option or a log without the scored columns; 3 MAP, LOG\n"
      "or GT missing or unreadable, or DIR not a writable folder; 4 MAP is not a placedb map;\n"
      "7 disk full (no partial page is left).\n\n"
      "Examples:\n"
      "  placedb report run.placedb run.csv gt_pairs.txt --out report/\n"
      "  placedb report run.placedb run.csv --out report/          # no ground truth\n"
      "  placedb report run.placedb run.csv gt_pairs.txt --out report/ --window 10\n"
      "  placedb demo --out d && placedb report d/demo.placedb d/run.csv \\\n"
      "      d/sequence/gt_pairs.txt --out d/report");
  app->add_option("MAP", request->map, "the map the run wrote")
      ->required()
      ->transform(mapArgument());
  app->add_option("LOG", request->log, "its per-frame CSV log (`placedb map --log`)")->required();
  app->add_option("GT", request->gt,
                  "ground-truth pairs file (optional: without it closures are not judged)");
  app->add_option("--out,-o", request->out, "folder for index.html")->required();
  app->add_option("--window,-w", request->window, "tolerance in frames, as for `placedb eval`")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app->add_option("--session", *session,
                  "session of MAP the log belongs to (default: the log's session column, else the "
                  "last)");
  app->add_option("--max-wrong", request->max_wrong, "wrong closures shown")->capture_default_str();
  app->add_option("--max-right", request->max_right, "right closures shown")->capture_default_str();
  return {app, [request, session, app]() {
            if (app->count("--session")) request->session = *session;
            const ReportSummary s = writeReport(*request);
            const std::string line =
                request->gt.empty()
                    ? fmt::format("report: {} ({} figures, {} closures shown, not judged)\n",
                                  s.page.string(), s.figures, s.unjudged_shown)
                    : fmt::format(
                          "report: {} ({} figures, {} wrong and {} right closures shown{})\n",
                          s.page.string(), s.figures, s.wrong_shown, s.right_shown,
                          s.unjudged_shown ? fmt::format(", {} to other sessions", s.unjudged_shown)
                                           : "");
            std::fputs(line.c_str(), stdout);
            if (s.missing_images)
              std::fputs(fmt::format("placedb: warning: {} frame images could not be read; the "
                                     "page names them\n",
                                     s.missing_images)
                             .c_str(),
                         stderr);
            return 0;
          }};
}

}  // namespace placedb::cli
