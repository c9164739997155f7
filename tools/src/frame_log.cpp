#include "frame_log.h"

#include <fmt/format.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>

#include "placedb/error.h"

namespace placedb::cli {
namespace {

const char* outcomeName(FrameOutcome outcome) {
  switch (outcome) {
    case FrameOutcome::kNewLocation:
      return "new";
    case FrameOutcome::kMerged:
      return "merged";
    case FrameOutcome::kBad:
      return "bad";
  }
  return "?";
}

// Enough digits to tell scores apart near the decision threshold, short enough to read.
std::string number(double value) { return fmt::format("{:.6g}", value); }
std::string millis(double value) { return fmt::format("{:.3f}", value); }

// EVALUATION.md: the score column is 0 where a check other than the final threshold (the ratio
// test, a geometric check) rejected the hypothesis; raw_score keeps the filter's value.
double scoredValue(const Hypothesis& h) {
  const std::string& why = h.rejected_reason;
  bool threshold_or_nothing = h.accepted || why.empty() || why == "below_threshold" ||
                              why == "no_hypothesis" || why == "bad frame";
  return threshold_or_nothing ? h.score : 0.0;
}

}  // namespace

const std::vector<std::string>& FrameLogWriter::columns() {
  static const std::vector<std::string> kColumns = {"frame",
                                                    "candidate_frames",
                                                    "score",
                                                    "accepted",
                                                    "time_ms",
                                                    "outcome",
                                                    "location",
                                                    "posterior",
                                                    "words_created",
                                                    "vocabulary_size",
                                                    "wm_size",
                                                    "stm_size",
                                                    "mean_quantisation_error",
                                                    "feature_count",
                                                    "transferred",
                                                    "retrieved",
                                                    "features_ms",
                                                    "quantisation_ms",
                                                    "likelihood_ms",
                                                    "filter_ms",
                                                    "memory_ms",
                                                    "storage_ms",
                                                    "session",
                                                    "other_candidates",
                                                    "rejected_reason",
                                                    "raw_score",
                                                    "inliers",
                                                    "matches",
                                                    "verification_ms",
                                                    "candidates_checked",
                                                    "stamp_ns"};
  return kColumns;
}

namespace {

std::string headerLine() {
  std::string header;
  for (const auto& name : FrameLogWriter::columns()) header += (header.empty() ? "" : ",") + name;
  return header;
}

[[noreturn]] void throwWriteError(const std::string& what, int error) {
  const bool full = error == ENOSPC || error == EFBIG || error == EDQUOT;
  throw Error(full ? ErrorCode::kDiskFull : ErrorCode::kIo,
              fmt::format("{}: {}", what, std::strerror(error)));
}

// Writes all of `text` or nothing: a short write is cut back to where it started.
void writeWhole(int fd, const std::string& text, off_t good_size, const std::string& what) {
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      int error = n < 0 ? errno : ENOSPC;
      // Shrinking needs no room; a later resume appends after the last whole row. Should the
      // cut fail too, the write's error is still the one to report.
      if (::ftruncate(fd, good_size) != 0) error = error == 0 ? errno : error;
      throwWriteError(what, error);
    }
    done += static_cast<std::size_t>(n);
  }
}

}  // namespace

void FrameLogWriter::checkAppendable(const std::filesystem::path& path,
                                     std::optional<std::int64_t> resumed_session) {
  namespace fs = std::filesystem;
  if (path == kStandardOutput) return;
  const std::string name = path.string();
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (!fs::exists(status)) {
    const fs::path folder = path.parent_path().empty() ? fs::path(".") : path.parent_path();
    if (!fs::is_directory(folder, ec))
      throw Error(ErrorCode::kIo, fmt::format("cannot write log {}: folder {} does not exist", name,
                                              folder.string()));
    if (::access(folder.c_str(), W_OK) != 0)
      throw Error(ErrorCode::kIo, fmt::format("cannot write log {}: folder {}: {}", name,
                                              folder.string(), std::strerror(errno)));
    return;
  }
  if (!fs::is_regular_file(status))
    throw Error(ErrorCode::kIo, fmt::format("cannot write log {}: not a regular file", name));
  if (::access(name.c_str(), W_OK) != 0)
    throw Error(ErrorCode::kIo, fmt::format("cannot write log {}: {}", name, std::strerror(errno)));
  if (fs::file_size(path, ec) == 0) return;
  const CsvTable existing = readCsv(path);
  if (existing.header != splitCsvLine(headerLine()))
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("log {} exists with other columns (not a log of this placedb): "
                            "give a new file",
                            name));
  if (existing.rows.empty()) return;
  const std::string& last = existing.cell(existing.rows.size() - 1, existing.column("session"));
  if (!resumed_session || last != std::to_string(*resumed_session))
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("log {} holds the rows of session {}; this run {}: give a new file "
                            "(appending would mix two runs)",
                            name, last,
                            resumed_session ? fmt::format("resumes session {}", *resumed_session)
                                            : std::string("starts a new session")));
}

FrameLogWriter::CutBack FrameLogWriter::cutBack(const std::filesystem::path& path,
                                                std::int64_t session, std::int64_t first_index) {
  CutBack cut;
  std::vector<std::int64_t>& dropped = cut.dropped;
  if (path == kStandardOutput) return cut;
  std::ifstream in(path, std::ios::binary);
  if (!in) return cut;  // no log yet
  const std::string name = path.string();
  const std::vector<std::string>& names = columns();
  const auto at = [&names](const char* column) {
    return static_cast<std::size_t>(std::find(names.begin(), names.end(), column) - names.begin());
  };
  const std::size_t frame_at = at("frame"), session_at = at("session");
  off_t keep = 0, offset = 0;
  bool header = true;
  for (std::string line; std::getline(in, line);) {
    const off_t next = offset + static_cast<off_t>(line.size()) + (in.eof() ? 0 : 1);
    if (header) {
      header = false;
      keep = next;
    } else if (!line.empty()) {
      const std::vector<std::string> fields = splitCsvLine(line);
      std::int64_t frame = -1;
      const bool ours =
          fields.size() == names.size() && fields[session_at] == std::to_string(session);
      if (ours) frame = std::stoll(fields[frame_at]);
      if (ours && frame >= first_index) {
        dropped.push_back(frame);
      } else if (dropped.empty()) {
        if (ours) cut.last_kept = frame;
        keep = next;
      } else {
        throw Error(ErrorCode::kInvalidArgument,
                    fmt::format("log {}: a row after frame {} is not of session {}: give a new "
                                "file",
                                name, dropped.back(), session));
      }
    }
    offset = next;
  }
  in.close();
  if (!dropped.empty() && ::truncate(name.c_str(), keep) != 0)
    throwWriteError("cannot cut back log " + name, errno);
  return cut;
}

FrameLogWriter::FrameLogWriter(const std::filesystem::path& path) : path_(path.string()) {
  fd_ = path_ == kStandardOutput
            ? ::fcntl(STDOUT_FILENO, F_DUPFD_CLOEXEC, 0)
            : ::open(path_.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd_ < 0)
    throw Error(ErrorCode::kIo,
                fmt::format("cannot write log {}: {}", path_, std::strerror(errno)));
  struct stat st {};
  if (::fstat(fd_, &st) != 0) {
    const int error = errno;
    ::close(fd_);
    throw Error(ErrorCode::kIo,
                fmt::format("cannot write log {}: {}", path_, std::strerror(error)));
  }
  size_ = st.st_size;
  if (size_ == 0) {
    const std::string header = headerLine() + "\n";
    try {
      writeWhole(fd_, header, 0, "cannot write log " + path_);
    } catch (...) {
      ::close(fd_);
      throw;
    }
    size_ += static_cast<off_t>(header.size());
  }
}

FrameLogWriter::~FrameLogWriter() {
  if (fd_ >= 0) ::close(fd_);
}

namespace {

// The row of `r`, in the order of FrameLogWriter::columns().
std::vector<std::string> fieldsOf(const FrameResult& r) {
  std::string same_session, other_sessions;
  for (const auto& ref : r.hypothesis.frames) {
    if (ref.session_id == r.session_id)
      same_session += (same_session.empty() ? "" : " ") + std::to_string(ref.source_index);
    else
      other_sessions += fmt::format("{}{}:{}", other_sessions.empty() ? "" : " ", ref.session_id,
                                    ref.source_index);
  }
  const StageTimes& t = r.times;
  auto count = [](std::size_t n) { return std::to_string(n); };
  // In the order of columns(); the check below keeps the two in step.
  std::vector<std::string> fields = {std::to_string(r.source_index),
                                     same_session,
                                     number(scoredValue(r.hypothesis)),
                                     r.hypothesis.accepted ? "1" : "0",
                                     millis(t.total),
                                     outcomeName(r.outcome),
                                     std::to_string(r.location_id),
                                     number(r.hypothesis.posterior),
                                     count(r.words_created),
                                     count(r.vocabulary_size),
                                     count(r.wm_size),
                                     count(r.stm_size),
                                     number(r.mean_quantisation_error),
                                     count(r.feature_count),
                                     count(r.transferred),
                                     count(r.retrieved),
                                     millis(t.features),
                                     millis(t.quantisation),
                                     millis(t.likelihood),
                                     millis(t.filter),
                                     millis(t.memory),
                                     millis(t.storage),
                                     std::to_string(r.session_id),
                                     other_sessions,
                                     csvField(r.hypothesis.rejected_reason),
                                     number(r.hypothesis.score),
                                     std::to_string(r.hypothesis.inliers),
                                     std::to_string(r.hypothesis.matches),
                                     millis(t.verification),
                                     std::to_string(r.hypothesis.candidates_checked),
                                     r.stamp_ns ? std::to_string(*r.stamp_ns) : std::string()};
  return fields;
}

}  // namespace

void FrameLogWriter::write(const FrameResult& r) { writeFields(fieldsOf(r)); }

void FrameLogWriter::writeFromMap(const FrameResult& r) {
  std::vector<std::string> fields = fieldsOf(r);
  for (const char* unknown :
       {"transferred", "retrieved", "inliers", "matches", "verification_ms", "candidates_checked"})
    fields.at(static_cast<std::size_t>(std::find(columns().begin(), columns().end(), unknown) -
                                       columns().begin())) = "";
  writeFields(fields);
}

void FrameLogWriter::writeFields(const std::vector<std::string>& fields) {
  if (fields.size() != columns().size())
    throw Error(ErrorCode::kInternal, "frame log: fields and columns differ");
  std::string row;
  for (const auto& field : fields) row += (row.empty() ? "" : ",") + field;
  row += "\n";
  writeWhole(fd_, row, size_, "cannot write log " + path_);
  size_ += static_cast<off_t>(row.size());
}

int CsvTable::column(const std::string& name) const {
  for (std::size_t i = 0; i < header.size(); ++i)
    if (header[i] == name) return static_cast<int>(i);
  return -1;
}

const std::string& CsvTable::cell(std::size_t row, int column) const {
  static const std::string kEmpty;
  if (column < 0 || row >= rows.size()) return kEmpty;
  const auto& fields = rows[row];
  return static_cast<std::size_t>(column) < fields.size() ? fields[column] : kEmpty;
}

std::vector<std::string> splitCsvLine(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        fields.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        fields.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      fields.emplace_back();
    } else if (c != '\r') {
      fields.back() += c;
    }
  }
  return fields;
}

std::string csvField(const std::string& text) {
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) {
    if (c == '"') quoted += '"';
    quoted += (c == '\n' || c == '\r') ? ' ' : c;
  }
  return quoted + "\"";
}

CsvTable readCsv(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorCode::kIo, fmt::format("cannot read {}", path.string()));
  CsvTable table;
  std::string line;
  bool first = true;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (first) {
      table.header = splitCsvLine(line);
      first = false;
      continue;
    }
    if (line.empty()) continue;  // Python's csv.DictReader skips blank rows too
    table.rows.push_back(splitCsvLine(line));
  }
  return table;
}

}  // namespace placedb::cli
