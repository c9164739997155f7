#pragma once
// Typed errors shared by every placedb layer. The command line maps ErrorCode to its exit codes,
// so a code once published keeps its number.
#include <stdexcept>
#include <string>

namespace placedb {

enum class ErrorCode : int {
  kInvalidArgument = 2,     // bad settings, bad command-line values
  kIo = 3,                  // unreadable source, image, or file
  kMapRefused = 4,          // not SQLite, not a placedb map, damaged, or newer than this binary
  kMapBusy = 5,             // another writer holds the map
  kReadOnly = 6,            // the map (or its folder) cannot be written
  kDiskFull = 7,            // the disk or SQLite's page limit is full
  kVocabularyRefused = 8,   // vocabulary file wrong magic/version/dimension/checksum/extractor
  kStorage = 9,             // any other SQLite failure
  kInternal = 10,           // a broken invariant: a bug
  kServerUnreachable = 11,  // the map's database server cannot be reached (or went away)
  kAuthRefused = 12,        // the map's database server refused the credentials
  kServerLost = 13,         // a writer lost the map's server and it did not come back in time
};

class Error : public std::runtime_error {
 public:
  Error(ErrorCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  ErrorCode code() const noexcept { return code_; }

 private:
  ErrorCode code_;
};

}  // namespace placedb
