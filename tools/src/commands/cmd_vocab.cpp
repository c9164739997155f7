#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "commands/commands.h"
#include "commands/vocab_transfer.h"
#include "map_argument.h"
#include "output_guard.h"
#include "placedb/error.h"
#include "placedb/map.h"
#include "placedb/storage/map_files.h"
#include "placedb/storage/map_store.h"
#include "vocabulary/vocabulary_file.h"
#include "whole_file.h"

namespace placedb::cli {

vocab::VocabularyData wordsOfMap(const std::string& map_path) {
  requireExistingMap(map_path);
  const auto store_owner = storage::openMapStore(map_path, storage::OpenMode::kReadOnly);
  storage::MapStore& store = *store_owner;
  vocab::VocabularyData data;
  auto last = store.lastSession();
  const auto imports = store.vocabularyImports();
  if (last) {
    data.settings = store.settings(last->id);
    // A setting absent from the table had its default when the session ran.
    const auto setting = [&data](const char* key, const char* absent) {
      const auto it = data.settings.find(key);
      return it == data.settings.end() ? std::string(absent) : it->second;
    };
    data.extractor = setting("extractor", toString(Options().extractor));
    data.unit = parseDistanceUnit(setting("distance_unit", toString(Options().distance_unit)));
  } else if (!imports.empty() && !imports.front().extractor.empty()) {
    // Only imported words: the file's own header again, so the export repeats it exactly.
    data.settings = imports.front().settings;
    data.extractor = imports.front().extractor;
    data.unit = parseDistanceUnit(imports.front().distance_unit);
  } else {
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("map {} has no session and no imported vocabulary", map_path));
  }
  data.type = DescriptorType::kFloat32;

  std::vector<std::vector<float>> rows;
  const std::int64_t max_id = store.maxWordId().value_or(0);
  constexpr std::int64_t kChunk = 20000;  // bounded statements, bounded memory per query
  for (std::int64_t first = 0; first <= max_id; first += kChunk) {
    std::vector<std::int64_t> ids;
    for (std::int64_t id = first; id < std::min(first + kChunk, max_id + 1); ++id)
      ids.push_back(id);
    for (const auto& word : store.loadWords(ids)) {
      if (word.type != storage::DescriptorKind::kFloat32)
        throw Error(ErrorCode::kInvalidArgument, "vocab export supports float descriptors only");
      if (data.dim == 0) data.dim = word.dim;
      if (word.dim != data.dim)
        throw Error(ErrorCode::kInternal, fmt::format("word {} has dimension {}, others {}",
                                                      word.id, word.dim, data.dim));
      data.ids.push_back(word.id);
      data.created_frames.push_back(word.created_frame.value_or(word.source_frame.value_or(-1)));
      rows.push_back(word.floats());
    }
  }
  data.descriptors = cv::Mat(static_cast<int>(rows.size()), std::max(data.dim, 1), CV_32F);
  for (std::size_t i = 0; i < rows.size(); ++i)
    std::copy(rows[i].begin(), rows[i].end(), data.descriptors.ptr<float>(static_cast<int>(i)));
  if (rows.empty()) data.descriptors = cv::Mat(0, data.dim, CV_32F);
  return data;
}

void writeVocabulary(const std::string& file, const vocab::VocabularyData& data, bool text) {
  // A device is written, a link's target replaced, as every export is.
  writeWholeFile(file, [&](std::FILE* out) {
    if (text)
      vocab::writeVocabularyText(out, data, file);
    else
      vocab::writeVocabularyFile(out, data);
  });
}

int runExport(const VocabRequest& request) {
  refuseMapAsOutput("vocab export", request.map_path, request.file);
  vocab::VocabularyData data = wordsOfMap(request.map_path);
  writeVocabulary(request.file, data, request.text);
  std::fputs(fmt::format("placedb: wrote {} words ({}, dimension {}) to {}\n", data.ids.size(),
                         data.extractor, data.dim, request.file)
                 .c_str(),
             stderr);
  return 0;
}

int runImport(const VocabRequest& request) {
  if (request.mode != "fixed" && request.mode != "seed")
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("--mode {} is not valid (valid: fixed|seed)", request.mode));
  // The map takes the extractor that made the words ("surf" or its signature "surf-64"): only
  // the header is read for it here. importVocabulary() checks the whole file before it writes,
  // and a map created for a file it refuses is removed below.
  Options options;
  vocab::VocabularyData header;
  if (!request.text) header = vocab::readVocabularyFile(request.file, {"", 0, true});
  const std::string named =
      request.text ? (request.extractor.empty() ? toString(Options().extractor) : request.extractor)
                   : header.extractor;
  options.extractor = parseExtractor(named.substr(0, named.find('-')));
  if (!request.extractor.empty() && request.extractor != toString(options.extractor))
    throw Error(ErrorCode::kVocabularyRefused,
                fmt::format("vocabulary file {} refused: its words are {} descriptors, not {}",
                            request.file, named, request.extractor));
  // A map on a server is a database placedb never deletes: a failed import leaves its tables.
  const bool created =
      !storage::isServerMap(request.map_path) && !std::filesystem::exists(request.map_path);
  std::size_t words = 0;
  try {
    auto map = Map::open(request.map_path, options);
    words = map->importVocabulary(
        request.file, request.text,
        request.mode == "fixed" ? VocabularyMode::kFixed : VocabularyMode::kSeed);
    map->close();
  } catch (...) {
    if (created) storage::removeMap(request.map_path);
    throw;
  }
  const std::string dimension =
      header.dim > 0 ? fmt::format(", dimension {}", header.dim) : std::string();
  std::fputs(fmt::format("placedb: imported {} words ({}{}) into {} as a {} vocabulary\n", words,
                         toString(options.extractor), dimension, request.map_path, request.mode)
                 .c_str(),
             stderr);
  return 0;
}

Command addVocabCommand(CLI::App& parent) {
  auto request = std::make_shared<VocabRequest>();
  CLI::App* app = parent.add_subcommand("vocab", "Export or import a map's visual vocabulary");
  app->footer(
      "Move a visual vocabulary between maps.\n\n"
      "Examples:\n"
      "  placedb vocab export run.placedb words.pvoc           binary, checksummed\n"
      "  placedb vocab export run.placedb words.txt --format rtabmap   RTAB-Map dictionary\n"
      "  placedb vocab import words.pvoc new.placedb --mode fixed");
  app->require_subcommand(1);
  CLI::App* exporter = app->add_subcommand("export", "Write every word of MAP to FILE");
  exporter->add_option("MAP", request->map_path, "map: a file or a postgresql:// URI")
      ->required()
      ->transform(mapArgument());
  exporter->add_option("FILE", request->file, "vocabulary file to write")->required();
  const auto addFormat = [&request](CLI::App* command) {
    command
        ->add_option("--format", request->format,
                     "placedb (binary, checksummed) or rtabmap (RTAB-Map's text dictionary: "
                     "`WordID Descriptors...N`, then `WordID d1 ... dN` lines)")
        ->check(CLI::IsMember({"placedb", "rtabmap"}));
    command->add_flag("--text", request->text, "the same as --format rtabmap");
  };
  addFormat(exporter);
  CLI::App* importer = app->add_subcommand("import", "Load FILE's words into MAP");
  importer->add_option("FILE", request->file, "vocabulary file")->required();
  importer->add_option("MAP", request->map_path, "map: a file or a postgresql:// URI")
      ->required()
      ->transform(mapArgument());
  importer
      ->add_option("--mode", request->mode,
                   "fixed: only these words, none created; seed: start from them")
      ->required();
  addFormat(importer);
  importer->add_option("--extractor", request->extractor,
                       "the extractor that made the words (text files only; default surf)");
  importer->footer(
      "MAP must be new (created here) or hold no frames and no words. The file is checked\n"
      "whole first: wrong magic, version, checksum, dimension or extractor, or a truncated\n"
      "file, is refused with its reason and nothing is written.\n\n"
      "  fixed  every later frame takes its nearest imported word; the vocabulary never grows\n"
      "  seed   the vocabulary starts from these words and grows as mapping goes on\n\n"
      "Then map as usual: placedb map new.placedb images/");
  return {app, [request, exporter]() {
            if (request->format == "rtabmap") request->text = true;
            return exporter->parsed() ? runExport(*request) : runImport(*request);
          }};
}

}  // namespace placedb::cli
