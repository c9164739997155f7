#include "exit_codes.h"

#include <fmt/format.h>

#include <cstdio>

namespace placedb::cli {
namespace {

std::string oneLine(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
  for (char& c : text)
    if (c == '\n' || c == '\r') c = ' ';
  return text;
}

}  // namespace

int exitCodeFor(ErrorCode code) {
  int value = static_cast<int>(code);
  // Codes are published by error.h in 2..13; anything else is a bug reported as internal.
  if (value < 2 || value > 13) return static_cast<int>(ErrorCode::kInternal);
  return value;
}

std::string exitCodeTable() {
  return "Exit status:\n"
         "   0  success\n"
         "   2  invalid argument: bad command line, unknown setting or bad value, an export onto\n"
         "      the map, a --log file of another run or format\n"
         "   3  I/O: unreadable source, image, list, log or config file (or a folder given as "
         "one)\n"
         "   4  map refused: not SQLite, not a placedb map, damaged pages, rows failing their\n"
         "      checksum or missing tables, newer than this binary, or a file with more than one\n"
         "      hard link; `placedb check` found damage\n"
         "   5  map busy: another writer holds the map\n"
         "   6  read-only: the map or its folder cannot be written, or a server map on a hot\n"
         "      standby (a read replica: map into its primary)\n"
         "   7  disk full (the map, the log or an export; nothing partial is left)\n"
         "   8  vocabulary file refused (magic, version, dimension, checksum, extractor)\n"
         "   9  other storage (SQLite or PostgreSQL) failure\n"
         "  10  internal error (a bug: please report it)\n"
         "  11  server unreachable: the map's PostgreSQL server cannot be reached or went away\n"
         "  12  server refused the credentials (wrong password, unknown role)\n"
         "  13  server lost: `map` lost the map's server and it did not come back within\n"
         "      --server-wait; every committed frame is kept and the next `map` resumes\n"
         "  14  live source stalled: the camera or stream sent nothing for 5 s; `map` closed\n"
         "      the session cleanly with every frame it took\n"
         "Ctrl-C, SIGTERM or SIGHUP during `map` finishes the current frame, closes the map\n"
         "cleanly (resumable) and exits 0.\n";
}

void printError(const std::string& message) {
  std::fputs(fmt::format("placedb: error: {}\n", oneLine(message)).c_str(), stderr);
}

void printNote(const std::string& message) {
  std::fputs(fmt::format("placedb: note: {}\n", oneLine(message)).c_str(), stderr);
}

void printWarning(const std::string& message) {
  std::fputs(fmt::format("placedb: warning: {}\n", oneLine(message)).c_str(), stderr);
}

}  // namespace placedb::cli
