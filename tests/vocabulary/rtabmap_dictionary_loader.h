#pragma once
// What RTAB-Map makes of a text dictionary (Kp/DictionaryPath): the parsing of
// VWDictionary::setFixedDictionary in RTAB-Map's corelib/src/VWDictionary.cpp (introlab/rtabmap
// at 5fad2d2), written again here from what it does, so that placedb's export is checked
// against the loader that will read it, not against placedb's own reader:
//
// - the first line is the header; it is cut into runs of digits and of other characters
//   (uSplitNumChar) and the first run that starts with a digit is the dimension, which must be
//   in 1..1000, else the file is refused and no word loads;
// - every further line is cut at single spaces, empty pieces dropped (uSplit(str, ' ')): a tab
//   is no separator; a line of exactly dimension + 1 pieces is a word, its id atoi() of the
//   first piece and each value the piece read by an std::istringstream in the "C" locale with
//   ',' turned into '.' (uStr2Float); any other non-empty line is skipped with a warning;
// - words go into a std::map<int, VisualWord*> by id, so a repeated id keeps the first word;
// - with a fixed dictionary the nearest word of every feature must have an id above 0
//   (UASSERT(fullResults.begin()->second > 0) in VWDictionary::addNewWords; ID_START = 1,
//   ID_INVALID = 0): a word 0 aborts RTAB-Map the first time a feature is nearest to it.
#include <cstdlib>
#include <fstream>
#include <locale>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace placedb::testing {

struct RtabmapDictionary {
  bool refused = false;  // the header's dimension was not valid
  int dimension = 0;
  std::map<int, std::vector<float>> words;  // as VWDictionary keeps them, by id
  std::vector<std::string> skipped_lines;   // "Cannot parse line" warnings
  int repeated_ids = 0;                     // words the map insert dropped
  int invalid_ids = 0;                      // words with an id below ID_START (1)
};

inline RtabmapDictionary loadRtabmapDictionary(const std::string& path) {
  constexpr int kIdStart = 1;
  RtabmapDictionary out;
  std::ifstream file(path);
  std::string line;
  std::getline(file, line);
  // uSplitNumChar, then the first piece starting with a digit.
  std::vector<std::string> runs;
  for (char c : line) {
    const bool digit = c >= '0' && c <= '9';
    const bool last_digit = !runs.empty() && !runs.back().empty() && runs.back().back() >= '0' &&
                            runs.back().back() <= '9';
    if (runs.empty() || digit != last_digit)
      runs.emplace_back(1, c);
    else
      runs.back() += c;
  }
  for (const auto& run : runs)
    if (run[0] >= '0' && run[0] <= '9') {
      out.dimension = std::atoi(run.c_str());
      break;
    }
  if (out.dimension <= 0 || out.dimension > 1000) {
    out.refused = true;
    return out;
  }
  while (file.good()) {
    std::getline(file, line);
    std::vector<std::string> pieces;
    std::string piece;
    for (char c : line) {
      if (c != ' ') {
        piece += c;
      } else if (!piece.empty()) {
        pieces.push_back(piece);
        piece.clear();
      }
    }
    if (!piece.empty()) pieces.push_back(piece);
    if (static_cast<int>(pieces.size()) == out.dimension + 1) {
      const int id = std::atoi(pieces[0].c_str());
      std::vector<float> descriptor;
      for (std::size_t i = 1; i < pieces.size(); ++i) {
        std::string text = pieces[i];
        for (char& c : text)
          if (c == ',') c = '.';
        float value = 0.0f;
        std::istringstream in(text);
        in.imbue(std::locale("C"));
        in >> value;
        descriptor.push_back(value);
      }
      if (id < kIdStart) ++out.invalid_ids;
      if (!out.words.emplace(id, descriptor).second) ++out.repeated_ids;
    } else if (!line.empty()) {
      out.skipped_lines.push_back(line);
    }
  }
  return out;
}

}  // namespace placedb::testing
