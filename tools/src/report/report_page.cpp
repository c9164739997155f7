#include "report/report_page.h"

#include <fmt/format.h>

namespace placedb::cli {
namespace {

const char* kStyle = R"(
body { font-family: sans-serif; margin: 1.5em auto; max-width: 1000px; color: #222; }
h1 { margin-bottom: 0.2em; }
.inputs { color: #555; font-size: 0.9em; }
.inputs code { word-break: break-all; }
table.scores { border-collapse: collapse; margin: 0.5em 0; }
table.scores td, table.scores th { border: 1px solid #ccc; padding: 0.2em 0.6em; text-align: left; }
table.scores td.value { font-family: monospace; text-align: right; }
.figures { display: grid; grid-template-columns: 1fr 1fr; gap: 16px; }
figure { margin: 0; }
figure img { width: 100%; border: 1px solid #ddd; }
figure.matrix img { width: 70%; image-rendering: pixelated; }
figcaption { color: #555; font-size: 0.9em; }
.pairs { display: flex; flex-wrap: wrap; gap: 12px; }
.pair { border: 2px solid #2ca02c; padding: 4px; font-size: 0.85em; }
.pair.wrong { border-color: #d62728; }
.pair.unjudged { border-color: #1f77b4; }
.pair .images { display: flex; gap: 4px; }
.pair .images div { width: 200px; }
.pair img { width: 200px; display: block; }
.missing { width: 200px; height: 150px; background: #eee; color: #a00; font-size: 0.85em;
           overflow-wrap: anywhere; display: flex; align-items: center; justify-content: center; }
)";

// Counts the pictures that decoded, for people (a line under the title) and for the headless
// browser test (the body attribute in a DOM dump).
const char* kScript = R"(
window.addEventListener('load', function () {
  var images = document.images, loaded = 0;
  for (var i = 0; i < images.length; ++i)
    if (images[i].complete && images[i].naturalWidth > 0) ++loaded;
  document.body.setAttribute('data-images-loaded', loaded + '/' + images.length);
  var line = document.getElementById('loaded');
  if (line && loaded < images.length)
    line.textContent = (images.length - loaded) + ' of ' + images.length +
                       ' pictures could not be shown.';
});
)";

// What each figure of the score table means, for a reader who has not read EVALUATION.md.
std::string meaning(const std::string& key) {
  if (key == "recall_at_100_precision")
    return "share of the loop frames found with a score above every wrong hypothesis (R@100P)";
  if (key == "accepted_precision") return "right closures among those the engine accepted";
  if (key == "accepted_recall") return "loop frames with a right accepted closure";
  if (key == "accepted_true") return "accepted closures that are right";
  if (key == "accepted_false") return "accepted closures that are wrong";
  if (key == "gt_loop_frames") return "frames that revisit a place, by the ground truth";
  if (key == "window") return "frames a candidate may be off the truth and still be right";
  if (key == "frames") return "frames in the log";
  if (key.rfind("time_ms", 0) == 0) return "time per frame (ms)";
  return "";
}

std::string scoreTable(const EvalFigures& figures) {
  std::string html =
      "<table class=\"scores\"><tr><th>figure</th><th>value</th><th>meaning</th></tr>\n";
  for (const auto& [key, value] : figureRows(figures))
    html += fmt::format("<tr><td>{}</td><td class=\"value\">{}</td><td>{}</td></tr>\n",
                        htmlEscape(key), htmlEscape(value), htmlEscape(meaning(key)));
  return html + "</table>\n";
}

std::string pictureHtml(const ReportPage::Picture& p) {
  if (!p.uri.empty())
    return fmt::format("<div><img src=\"{}\" alt=\"frame {}\" title=\"{}\"></div>", p.uri, p.frame,
                       htmlEscape(p.path));
  const std::string why =
      p.path.empty() ? fmt::format("frame {} is not in the map", p.frame) : "cannot read " + p.path;
  return fmt::format("<div class=\"missing\">{}</div>", htmlEscape(why));
}

std::string truthText(const GalleryEntry& e) {
  if (e.truth.empty()) return "no loop here in the ground truth";
  std::string frames;
  for (std::int64_t r : e.truth) frames += (frames.empty() ? "" : ", ") + std::to_string(r);
  return "ground truth: " + frames;
}

// `judged`: a ground truth gave each closure a verdict (a green or red frame, the truth below).
std::string pairsHtml(const std::vector<ReportPage::Pair>& pairs, bool judged) {
  std::string html = "<div class=\"pairs\">\n";
  for (const auto& p : pairs) {
    const GalleryEntry& e = p.closure;
    const std::string matched =
        e.matched_session ? fmt::format("session {} frame {}", e.matched_session, e.matched)
                          : fmt::format("frame {}", e.matched);
    html += fmt::format(
        "<div class=\"pair {}\"><div class=\"images\">{}{}</div>"
        "<div>frame {} &rarr; {}, score {:.3f}{}</div></div>\n",
        !judged   ? "unjudged"
        : e.right ? "right"
                  : "wrong",
        pictureHtml(p.query), pictureHtml(p.matched), e.frame, matched, e.score,
        !judged || e.right ? "" : "<br>" + htmlEscape(truthText(e)));
  }
  return html + "</div>\n";
}

// What a run says without ground truth: its length, closures and time.
std::string runTable(const EvalFigures& f, std::size_t closures) {
  std::string html =
      "<table class=\"scores\"><tr><th>figure</th><th>value</th><th>meaning</th></tr>\n";
  const auto row = [&](const std::string& key, const std::string& value, const char* meaning) {
    html += fmt::format("<tr><td>{}</td><td class=\"value\">{}</td><td>{}</td></tr>\n", key, value,
                        meaning);
  };
  row("frames", std::to_string(f.frames), "frames in the log");
  row("accepted_closures", std::to_string(closures), "frames whose loop closure was accepted");
  if (f.time_ms_mean) row("time_ms_mean", fmt::format("{:.2f}", *f.time_ms_mean), "ms a frame");
  if (f.time_ms_p99) row("time_ms_p99", fmt::format("{:.2f}", *f.time_ms_p99), "99th percentile");
  return html + "</table>\n";
}

}  // namespace

std::string reportHtml(const ReportPage& page) {
  const EvalFigures& f = page.figures;
  std::string html = fmt::format(
      "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
      "<title>placedb report: {}</title>\n<style>{}</style>\n<script>{}</script>\n</head>\n"
      "<body>\n<h1>placedb report</h1>\n"
      "<p class=\"inputs\">map <code>{}</code> (session {}), log <code>{}</code>, {}.</p>\n"
      "<p id=\"loaded\"></p>\n",
      htmlEscape(page.log), kStyle, kScript, htmlEscape(page.map), page.session,
      htmlEscape(page.log),
      page.judged ? fmt::format("ground truth <code>{}</code>, window {} frames",
                                htmlEscape(page.gt), f.window)
                  : std::string("no ground truth: closures are shown without a verdict"));

  if (page.judged)
    html +=
        "<h2>Scores</h2>\n<p>As <code>placedb eval</code> and <code>score_loops.py</code> "
        "compute them.</p>\n" +
        scoreTable(f);
  else
    html += "<h2>The run</h2>\n" + runTable(f, page.unjudged_total + page.other_sessions_total);

  html += "<h2>Figures</h2>\n<div class=\"figures\">\n";
  for (const auto& plot : page.plots)
    html += fmt::format(
        "<figure{}><img src=\"{}\" alt=\"{}\"><figcaption><b>{}</b>: {}</figcaption></figure>\n",
        plot.file == "loop_matrix.png" ? " class=\"matrix\"" : "", plot.uri, htmlEscape(plot.file),
        htmlEscape(plot.file), htmlEscape(plot.what));
  html += "</div>\n";

  if (page.judged) {
    html +=
        "<h2>Accepted loop closures</h2>\n<p>Each pair: the frame on the left, the frame the "
        "engine matched it with on the right. Wrong ones (red frame) first, then right ones "
        "(green).</p>\n";
    html += fmt::format("<h3>Wrong: {}</h3>\n", page.wrong_total);
    if (page.wrong_total == 0) html += "<p>None: every accepted closure is right.</p>\n";
    if (page.wrong.size() < page.wrong_total)
      html += fmt::format("<p>The first {} of {} are shown.</p>\n", page.wrong.size(),
                          page.wrong_total);
    html += pairsHtml(page.wrong, true);
    html += fmt::format("<h3>Right: {}</h3>\n", page.right_total);
    if (page.right.size() < page.right_total)
      html += fmt::format(
          "<p>A sample of {} of {}, evenly spread over the run (first and last included).</p>\n",
          page.right.size(), page.right_total);
    html += pairsHtml(page.right, true);
  } else {
    html += fmt::format(
        "<h2>Accepted loop closures: {}</h2>\n<p>Each pair: the frame on the left, the frame "
        "the engine matched it with on the right.{}</p>\n",
        page.unjudged_total,
        page.unjudged.size() < page.unjudged_total
            ? fmt::format(" A sample of {}, evenly spread over the run (first and last "
                          "included).",
                          page.unjudged.size())
            : "");
    html += pairsHtml(page.unjudged, false);
  }
  if (page.other_sessions_total > 0) {
    html += fmt::format(
        "<h2>Closures to other sessions: {}</h2>\n<p>Frames of this session matched with "
        "places of other sessions of the map; a ground truth of one sequence cannot judge them.{}"
        "</p>\n",
        page.other_sessions_total,
        page.other_sessions.size() < page.other_sessions_total
            ? fmt::format(" A sample of {}.", page.other_sessions.size())
            : "");
    html += pairsHtml(page.other_sessions, false);
  }
  return html + "</body>\n</html>\n";
}

}  // namespace placedb::cli
