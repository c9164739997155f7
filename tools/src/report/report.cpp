#include "report/report.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "base64.h"
#include "frame_log.h"
#include "placedb/error.h"
#include "placedb/storage/map_store.h"
#include "report/evaluation_run.h"
#include "report/report_page.h"
#include "sources/image_source.h"
#include "whole_file.h"

namespace placedb::cli {
namespace fs = std::filesystem;
namespace {

constexpr int kThumbnailWidth = 200;  // two pairs side by side on the page (report_page.cpp)

// The plots are drawn into a folder of their own outside DIR and inlined from there, so a run
// refused half way leaves nothing in DIR; the folder goes when the report is done or refused.
class ScratchFolder {
 public:
  ScratchFolder()
      : path_(fs::temp_directory_path() / fmt::format("placedb-report-{}", ::getpid())) {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  ~ScratchFolder() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  ScratchFolder(const ScratchFolder&) = delete;
  ScratchFolder& operator=(const ScratchFolder&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

void requireReadableFile(const fs::path& path, const char* what) {
  std::error_code ec;
  if (!fs::exists(path, ec))
    throw Error(ErrorCode::kIo,
                fmt::format("cannot read {} {}: no such file", what, path.string()));
  if (fs::is_directory(path, ec))
    throw Error(ErrorCode::kIo,
                fmt::format("cannot read {} {}: it is a folder, not a file", what, path.string()));
  if (::access(path.c_str(), R_OK) != 0)
    throw Error(ErrorCode::kIo,
                fmt::format("cannot read {} {}: {}", what, path.string(), std::strerror(errno)));
}

// DIR may exist (a folder: index.html in it is replaced) or be made; the first folder of it
// that exists must be writable.
void requireWritableFolder(const fs::path& out) {
  std::error_code ec;
  if (fs::exists(out, ec) && !fs::is_directory(out, ec))
    throw Error(
        ErrorCode::kIo,
        fmt::format("cannot write report into {}: it is a file, not a folder", out.string()));
  fs::path existing = fs::absolute(out, ec);
  while (!existing.empty() && !fs::exists(existing, ec)) existing = existing.parent_path();
  if (!fs::is_directory(existing, ec))
    throw Error(ErrorCode::kIo, fmt::format("cannot write report into {}: {} is not a folder",
                                            out.string(), existing.string()));
  if (::access(existing.c_str(), W_OK) != 0)
    throw Error(ErrorCode::kIo, fmt::format("cannot write report into {}: {}: {}", out.string(),
                                            existing.string(), std::strerror(errno)));
}

std::vector<std::uint8_t> readBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorCode::kIo, fmt::format("cannot read {}", path.string()));
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A frame's stored path is as `map` saw it: absolute, or relative to the folder it ran in. A
// relative one that is not found from here is looked for under the session's source folder,
// by its trailing components (a list file's paths are relative to the list file).
fs::path locateImage(const std::string& stored, const fs::path& source) {
  std::error_code ec;
  const fs::path path(stored);
  if (fs::is_regular_file(path, ec)) return path;
  if (path.is_absolute()) return {};
  const fs::path base = fs::is_directory(source, ec) ? source : source.parent_path();
  const std::vector<fs::path> parts(path.begin(), path.end());
  for (std::size_t first = 0; first < parts.size(); ++first) {
    fs::path tail;
    for (std::size_t i = first; i < parts.size(); ++i) tail /= parts[i];
    if (fs::is_regular_file(base / tail, ec)) return base / tail;
  }
  return {};
}

// A JPEG data: URI of the image shrunk to the thumbnail width; empty when it cannot be read.
std::string thumbnailOf(cv::Mat image) {
  if (image.empty()) return {};
  try {
    const double scale = static_cast<double>(kThumbnailWidth) / image.cols;
    if (scale < 1.0)
      cv::resize(image, image, cv::Size(), scale, scale, cv::INTER_AREA);  // no aliasing
    std::vector<std::uint8_t> jpeg;
    if (!cv::imencode(".jpg", image, jpeg, {cv::IMWRITE_JPEG_QUALITY, 85})) return {};
    return "data:image/jpeg;base64," + base64Encode(jpeg);
  } catch (const cv::Exception&) {
    return {};
  }
}

// A frame's image as the map stores its path: an image file (found as locateImage finds it), or a
// frame of a video ("VIDEO#INDEX") or bag ("BAG#TOPIC#INDEX"), read from the source at its index.
// Sources stay open between frames: a report asks one video for many.
class FrameImages {
 public:
  cv::Mat read(const std::string& stored, const fs::path& session_source) {
    const fs::path file = locateImage(stored, session_source);
    if (!file.empty()) {
      try {
        return cv::imread(file.string(), cv::IMREAD_COLOR);
      } catch (const cv::Exception&) {
        return {};
      }
    }
    const auto frame_in = parseFramePathInSource(stored);
    if (!frame_in) return {};
    SourceOptions options;
    options.topic = frame_in->topic;
    const std::int64_t index = frame_in->index;
    const std::string key = frame_in->source + "#" + frame_in->topic;
    try {
      // A video seeks forward only: an earlier frame reopens it.
      Open& open = sources_[key];
      if (!open.source || index < open.next) {
        open.source = ImageSource::open(frame_in->source, options);
        open.next = 0;
      }
      open.source->seek(index);
      SourceFrame frame;
      if (!open.source->read(frame) || frame.index != index) return {};
      open.next = index + 1;
      return frame.image;
    } catch (const std::exception&) {  // the source moved or cannot be read: a grey box
      sources_.erase(key);
      return {};
    }
  }

 private:
  struct Open {
    std::unique_ptr<ImageSource> source;
    std::int64_t next = 0;  // the index the next read() gives
  };
  std::map<std::string, Open> sources_;
};

// The session in the log's first row; nullopt for a log without the column (the bare format).
std::optional<std::int64_t> sessionOfLog(const fs::path& log) {
  const CsvTable table = readCsv(log);
  const std::string& cell = table.cell(0, table.column("session"));
  char* end = nullptr;
  const long long id = std::strtoll(cell.c_str(), &end, 10);
  if (cell.empty() || *end != '\0') return std::nullopt;
  return id;
}

}  // namespace

std::string htmlEscape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

Gallery closureGallery(const Evaluation& evaluation, const GroundTruth& gt, std::size_t max_wrong,
                       std::size_t max_right) {
  Gallery gallery;
  const int window = evaluation.figures.window;
  for (const auto& f : evaluation.frames) {
    if (!f.accepted || f.candidates.empty()) continue;
    GalleryEntry entry;
    entry.frame = f.frame;
    entry.matched = f.candidates.front();
    entry.score = f.score;
    entry.right = f.correct;
    if (auto refs = gt.find(f.frame); refs != gt.end()) {
      entry.truth.assign(refs->second.begin(), refs->second.end());
      // The candidate that made the closure right, as evaluate() judged it.
      auto near_truth = [&](std::int64_t c) {
        return std::any_of(refs->second.begin(), refs->second.end(),
                           [&](std::int64_t r) { return std::llabs(c - r) <= window; });
      };
      auto it = std::find_if(f.candidates.begin(), f.candidates.end(), near_truth);
      if (entry.right && it != f.candidates.end()) entry.matched = *it;
    }
    (entry.right ? gallery.right : gallery.wrong).push_back(std::move(entry));
  }
  gallery.wrong_total = gallery.wrong.size();
  gallery.right_total = gallery.right.size();
  if (gallery.wrong.size() > max_wrong) gallery.wrong.resize(max_wrong);
  gallery.right = spreadSample(std::move(gallery.right), max_right);
  return gallery;
}

std::vector<GalleryEntry> spreadSample(std::vector<GalleryEntry> entries, std::size_t n) {
  if (entries.size() <= n) return entries;
  std::vector<GalleryEntry> sample;
  const std::size_t size = entries.size();
  for (std::size_t k = 0; k < n; ++k)
    sample.push_back(entries[n == 1 ? 0 : k * (size - 1) / (n - 1)]);
  return sample;
}

std::vector<GalleryEntry> otherSessionClosures(const CsvTable& log) {
  std::vector<GalleryEntry> out;
  const int frame = log.column("frame"), accepted = log.column("accepted"),
            same = log.column("candidate_frames"), other = log.column("other_candidates"),
            score = log.column("score");
  if (other < 0) return out;
  for (std::size_t r = 0; r < log.rows.size(); ++r) {
    const std::string& others = log.cell(r, other);
    if (log.cell(r, accepted) != "1" || !log.cell(r, same).empty() || others.empty()) continue;
    // "SESSION:INDEX SESSION:INDEX ...": the first is the best candidate.
    long long session = 0, index = 0;
    if (std::sscanf(others.c_str(), "%lld:%lld", &session, &index) != 2) continue;
    GalleryEntry e;
    e.frame = std::strtoll(log.cell(r, frame).c_str(), nullptr, 10);
    e.matched = index;
    e.matched_session = session;
    e.score = std::strtod(log.cell(r, score).c_str(), nullptr);
    out.push_back(e);
  }
  return out;
}

ReportSummary writeReport(const ReportRequest& request) {
  // Every refusal comes before DIR is touched.
  if (!storage::isServerMap(request.map.string())) requireReadableFile(request.map, "map");
  requireReadableFile(request.log, "log");
  const bool judged = !request.gt.empty();
  if (judged) requireReadableFile(request.gt, "ground truth");
  requireWritableFolder(request.out);

  const auto store_owner =
      storage::openMapStore(request.map.string(), storage::OpenMode::kReadOnly);
  storage::MapStore& store = *store_owner;
  // The log names the session that wrote it: its thumbnails come from that session's frames.
  const std::optional<std::int64_t> wanted =
      request.session ? request.session : sessionOfLog(request.log);
  std::optional<storage::SessionRecord> session;
  for (auto& s : store.sessions())
    if (!wanted || s.id == *wanted) session = s;
  if (!session)
    throw Error(
        ErrorCode::kInvalidArgument,
        wanted ? fmt::format("map {} has no session {}{}", request.map.string(), *wanted,
                             request.session ? "" : " (the session of the log's rows)")
               : fmt::format("map {} has no session: map a sequence first", request.map.string()));
  // (session, source index) -> stored path, for every session: closures reach earlier ones.
  std::map<std::pair<std::int64_t, std::int64_t>, std::string> image_of;
  std::map<std::int64_t, std::string> source_of;
  for (const auto& s : store.sessions()) {
    source_of[s.id] = s.source;
    for (const auto& frame : store.frames(s.id))
      image_of[{s.id, frame.source_index}] = frame.source_path;
  }

  ScratchFolder scratch;
  EvalRequest eval;
  eval.log = request.log;
  eval.gt = request.gt;
  eval.window = request.window;
  eval.plots_dir = scratch.path();
  eval.map_path = request.map.string();
  eval.session = session->id;
  const EvalOutcome outcome = runEvaluation(eval);
  const GroundTruth gt = judged ? loadGroundTruth(request.gt) : GroundTruth{};

  ReportPage page;
  page.map = request.map.string();
  page.log = request.log.string();
  page.gt = request.gt.string();
  page.judged = judged;
  page.session = session->id;
  page.figures = outcome.evaluation.figures;
  for (const auto& plot : outcome.plots) {
    // Without ground truth the precision-recall curve says nothing; the score per frame and
    // the loop matrix show the accepted closures without a verdict.
    if (!judged && plot.file == "precision_recall.png") continue;
    page.plots.push_back(
        {plot.file, plot.what,
         "data:image/png;base64," + base64Encode(readBytes(scratch.path() / plot.file))});
  }

  ReportSummary summary;
  // Without ground truth every accepted closure lands among the "wrong" ones: all of them are
  // taken, then sampled over the run like the right ones.
  const Gallery gallery = closureGallery(outcome.evaluation, gt,
                                         judged ? request.max_wrong : SIZE_MAX, request.max_right);
  page.wrong_total = gallery.wrong_total;
  page.right_total = gallery.right_total;
  std::map<std::pair<std::int64_t, std::int64_t>, std::string> thumbnails;  // encoded once
  FrameImages images;
  auto picture = [&](std::int64_t session_id, std::int64_t frame) -> ReportPage::Picture {
    auto stored = image_of.find({session_id, frame});
    ReportPage::Picture p{frame, stored == image_of.end() ? std::string() : stored->second, {}};
    auto cached = thumbnails.find({session_id, frame});
    if (cached == thumbnails.end())
      cached = thumbnails
                   .emplace(std::pair(session_id, frame),
                            thumbnailOf(images.read(p.path, source_of[session_id])))
                   .first;
    p.uri = cached->second;
    if (p.uri.empty()) ++summary.missing_images;
    return p;
  };
  auto pair = [&](const GalleryEntry& e) {
    return ReportPage::Pair{
        e, picture(session->id, e.frame),
        picture(e.matched_session ? e.matched_session : session->id, e.matched)};
  };
  if (judged) {
    for (const auto& e : gallery.wrong) page.wrong.push_back(pair(e));
    for (const auto& e : gallery.right) page.right.push_back(pair(e));
  } else {
    page.unjudged_total = gallery.wrong_total;
    for (const auto& e : spreadSample(gallery.wrong, request.max_wrong + request.max_right))
      page.unjudged.push_back(pair(e));
  }
  const auto others = otherSessionClosures(readCsv(request.log));
  page.other_sessions_total = others.size();
  for (const auto& e : spreadSample(others, request.max_right))
    page.other_sessions.push_back(pair(e));

  std::error_code ec;
  fs::create_directories(request.out, ec);
  if (ec)
    throw Error(ErrorCode::kIo,
                fmt::format("cannot create {}: {}", request.out.string(), ec.message()));
  summary.page = request.out / "index.html";
  writeWholeFile(summary.page, reportHtml(page));
  summary.figures = page.plots.size();
  summary.wrong_shown = page.wrong.size();
  summary.right_shown = page.right.size();
  summary.unjudged_shown = page.unjudged.size() + page.other_sessions.size();
  return summary;
}

}  // namespace placedb::cli
