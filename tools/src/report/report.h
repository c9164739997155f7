#pragma once
// `placedb report`: one HTML page about a run, for a person to read: the score table of
// `placedb eval`, its figures, and thumbnails of the accepted closures (query frame beside the
// frame it was matched with), the wrong ones first. Every image is inlined as a data: URI, so
// DIR/index.html is the whole report and can be mailed or attached on its own.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "report/eval.h"

namespace placedb::cli {

struct ReportRequest {
  std::filesystem::path map, log, out;
  std::filesystem::path gt;  // empty: no ground truth, the closures are shown without a verdict
  int window = 0;
  // The session of the map the log belongs to; default: the log's `session` column, else the
  // map's last session.
  std::optional<std::int64_t> session;
  std::size_t max_wrong = 48;  // wrong closures shown (all of them up to this)
  std::size_t max_right = 24;  // right closures shown, spread over the run
};

struct ReportSummary {
  std::filesystem::path page;
  std::size_t figures = 0;
  std::size_t wrong_shown = 0, right_shown = 0;
  std::size_t unjudged_shown =
      0;  // closures shown without a verdict (no ground truth, other sessions)
  std::size_t missing_images = 0;  // frames whose image could not be read: a note, not a thumbnail
};

// Everything that can be refused (map, log, ground truth, the folder) is checked before DIR is
// made or written. Throws placedb::Error: kIo (unreadable input, DIR not a folder or not
// writable), kInvalidArgument (log lacks a column), kMapRefused, kDiskFull.
ReportSummary writeReport(const ReportRequest& request);

// One accepted closure to show: the query frame and the frame it was matched with.
struct GalleryEntry {
  std::int64_t frame = 0, matched = 0;
  std::int64_t matched_session = 0;  // the session of `matched` when it is another one, else 0
  double score = 0;
  bool right = false;
  std::vector<std::int64_t> truth;  // the frames the ground truth pairs `frame` with
};

struct Gallery {
  std::vector<GalleryEntry> wrong, right;
  std::size_t wrong_total = 0, right_total = 0;
};

// The wrong accepted closures in frame order, at most `max_wrong`, and at most `max_right` right
// ones evenly spread over the run. A right closure shows the candidate that is right; a wrong
// one its first candidate.
Gallery closureGallery(const Evaluation& evaluation, const GroundTruth& gt, std::size_t max_wrong,
                       std::size_t max_right);

// At most `n` of `entries`, evenly spread, first and last included, so a sample covers the run.
std::vector<GalleryEntry> spreadSample(std::vector<GalleryEntry> entries, std::size_t n);

// Accepted closures whose matched frames all belong to other sessions (the log's
// other_candidates): the ground truth of one sequence cannot judge them. In frame order.
std::vector<GalleryEntry> otherSessionClosures(const CsvTable& log);

// Text made safe inside HTML elements and quoted attributes.
std::string htmlEscape(const std::string& text);

}  // namespace placedb::cli
