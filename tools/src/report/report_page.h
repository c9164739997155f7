#pragma once
// The HTML of `placedb report`, from what report.cpp gathered: no file access here, so the
// page's layout can be read (and changed) apart from the work of making its pictures.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "report/eval.h"
#include "report/report.h"

namespace placedb::cli {

struct ReportPage {
  std::string map, log, gt;
  std::int64_t session = 0;
  EvalFigures figures;

  struct Plot {
    std::string file, what, uri;
  };
  std::vector<Plot> plots;

  struct Picture {
    std::int64_t frame = 0;
    std::string path;  // as the map stores it; empty when the map has no such frame
    std::string uri;   // empty when the image could not be read
  };
  struct Pair {
    GalleryEntry closure;
    Picture query, matched;
  };
  std::vector<Pair> wrong, right;
  std::size_t wrong_total = 0, right_total = 0;
  // Without ground truth (`judged` false) every closure of the session is in `unjudged`.
  bool judged = true;
  std::vector<Pair> unjudged, other_sessions;
  std::size_t unjudged_total = 0, other_sessions_total = 0;
};

// A whole page, styles and a small script included. The script counts the images that loaded
// and writes "loaded/total" into <body data-images-loaded>, so a headless browser's DOM dump
// tells whether every picture of the page decodes.
std::string reportHtml(const ReportPage& page);

}  // namespace placedb::cli
