#pragma once
// The per-frame CSV log of a mapping run and a small CSV reader for `eval`. Its first columns are
// the scored format of ../shared/EVALUATION.md (frame, candidate_frames, score, accepted,
// time_ms); what each column holds is docs/log.md's table, which tests/cli/log_doc_test.cpp keeps
// in step with columns().
//
// score is 0 where a check other than the final threshold (the ratio test) rejected the
// hypothesis, as EVALUATION.md asks; raw_score is the filter's loop probability regardless.
// candidate_frames holds the source indices of the hypothesis' frames from this session only:
// frames of earlier sessions are not indices of this source, so they go to other_candidates as
// "session:index" pairs.
#include <sys/types.h>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "placedb/map.h"

namespace placedb::cli {

// `--log -`: the rows go to standard output (everything else `map` prints goes to stderr).
inline const std::filesystem::path kStandardOutput = "-";

class FrameLogWriter {
 public:
  // Appends to an existing non-empty log (no second header); creates it otherwise.
  // Throws placedb::Error(kIo) when it cannot be opened.
  explicit FrameLogWriter(const std::filesystem::path& path);
  // Whether a run may write to the log at `path`, checked before the run writes anything: its
  // folder must exist and be writable, and an existing log must have these columns and end
  // with rows of `resumed_session` (the session this run continues; nullopt for a new one), so
  // one log never mixes two runs. Throws placedb::Error: kIo (cannot write), kInvalidArgument.
  static void checkAppendable(const std::filesystem::path& path,
                              std::optional<std::int64_t> resumed_session);
  struct CutBack {
    std::vector<std::int64_t> dropped;      // frames whose rows were cut off, in order
    std::optional<std::int64_t> last_kept;  // the session's last row left (none: no row)
  };
  // Rows of `session` from frame `first_index` on, which a resume maps again: the map lost their
  // commits (a power cut can take the write-ahead log with it) after the log had them. They are
  // cut off so that each frame is in the log once. Nothing to cut in standard output.
  static CutBack cutBack(const std::filesystem::path& path, std::int64_t session,
                         std::int64_t first_index);
  ~FrameLogWriter();
  FrameLogWriter(const FrameLogWriter&) = delete;
  FrameLogWriter& operator=(const FrameLogWriter&) = delete;

  // One write() per row, so a killed run keeps its rows. A row the disk has no room for is
  // cut back off (kDiskFull), so the log never holds a partial row.
  void write(const FrameResult& result);
  // A row rebuilt from the map (log_recovery.h) for a frame the map holds and the log lacks: the
  // columns the map does not keep (transferred, retrieved, inliers, matches, verification_ms,
  // candidates_checked) are left empty.
  void writeFromMap(const FrameResult& result);

  static const std::vector<std::string>& columns();

 private:
  void writeFields(const std::vector<std::string>& fields);

  int fd_ = -1;
  std::string path_;
  off_t size_ = 0;  // bytes of whole rows
};

// A CSV table with a header row; fields may be quoted ("a, b" and "" escapes).
struct CsvTable {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;

  // -1 when absent.
  int column(const std::string& name) const;
  // Empty when the column is absent or the row is short.
  const std::string& cell(std::size_t row, int column) const;
};

// Throws placedb::Error(kIo) when unreadable.
CsvTable readCsv(const std::filesystem::path& path);
std::vector<std::string> splitCsvLine(const std::string& line);
std::string csvField(const std::string& text);  // quotes when needed

}  // namespace placedb::cli
