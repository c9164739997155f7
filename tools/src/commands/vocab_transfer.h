#pragma once
// `placedb vocab export` and `import` as functions, for the command line and the Python module.
// Both report what they did in one line on stderr and return the exit status (0).
#include <string>

#include "vocabulary/vocabulary_file.h"

namespace placedb::cli {

struct VocabRequest {
  std::string map_path, file, mode = "fixed", extractor;
  std::string format = "placedb";  // placedb | rtabmap (--text)
  bool text = false;               // RTAB-Map's text dictionary
};

// Every word stored in the map (all memory tiers), ascending ids, with the last session's
// settings: the extractor and distance unit the words were made with.
vocab::VocabularyData wordsOfMap(const std::string& map_path);
// Writes `data` to `file` through the one writer of whole files (whole_file.h): placedb's binary
// format, or with `text` RTAB-Map's dictionary.
void writeVocabulary(const std::string& file, const vocab::VocabularyData& data, bool text);
// Writes every word of request.map_path to request.file.
int runExport(const VocabRequest& request);
// Starts request.map_path (new, or without frames and words) from request.file's words; a map
// created for a file that is refused is removed again.
int runImport(const VocabRequest& request);

}  // namespace placedb::cli
