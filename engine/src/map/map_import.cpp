// Importing a vocabulary file into a new map: the file is read and checked whole, then its words,
// their index and the import's provenance are written in one transaction.
#include <fmt/format.h>

#include <boost/crc.hpp>
#include <filesystem>
#include <fstream>

#include "map/map_impl.h"
#include "vocabulary/vocabulary_file.h"

namespace placedb {
namespace {

// CRC-32 of the file's bytes, as 8 hex digits: enough to tell two imported files apart.
std::string fileChecksum(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorCode::kIo, fmt::format("cannot read vocabulary file {}", path));
  boost::crc_32_type crc;
  char buffer[1 << 16];
  while (in.read(buffer, sizeof buffer) || in.gcount() > 0)
    crc.process_bytes(buffer, static_cast<std::size_t>(in.gcount()));
  return fmt::format("crc32:{:08x}", crc.checksum());
}

// The file names its extractor either as a setting ("surf", CLI exports) or by signature
// ("surf-64", engine snapshots).
bool sameExtractor(const std::string& named, const Options& options, const std::string& signature) {
  return named == toString(options.extractor) || named == signature;
}

}  // namespace

std::size_t MapImpl::importVocabulary(const std::string& file, bool text, VocabularyMode mode) {
  requireWritable("importVocabulary");
  if (session_id_)
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("{}: a vocabulary is imported before any session", store_->path()));
  // The vocabulary becomes the main line's memory: no other writer may be starting the map.
  if (!store_->claimMainLine())
    throw Error(ErrorCode::kMapBusy,
                fmt::format("{} is busy: another placedb writer has it open", store_->path()));
  const std::int64_t frames = store_->frameCount(), words = store_->wordCount();
  if (frames > 0 || words > 0)
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("{}: a vocabulary is imported into a new map only; this one already "
                            "holds {} frames and {} words",
                            store_->path(), frames, words));

  // Everything the file says is checked before the map is touched.
  vocab::VocabularyData data = text ? vocab::readVocabularyText(file, extractor_->dim())
                                    : vocab::readVocabularyFile(file, {"", extractor_->dim()});
  if (text) data.extractor = toString(options_.extractor);
  if (!sameExtractor(data.extractor, options_, extractor_->signature()))
    throw Error(ErrorCode::kVocabularyRefused,
                fmt::format("vocabulary file {} refused: its words are {} descriptors, the map "
                            "uses {} (open the map with extractor={})",
                            file, data.extractor, extractor_->signature(), data.extractor));
  if (data.type != DescriptorType::kFloat32)
    throw Error(
        ErrorCode::kVocabularyRefused,
        fmt::format("vocabulary file {} refused: only float descriptors can be imported", file));
  const std::string checksum = fileChecksum(file);

  try {
    auto tx = store_->begin();
    storage::VocabularyImportRecord record;
    record.file = std::filesystem::absolute(file).string();
    record.checksum = checksum;
    record.word_count = static_cast<std::int64_t>(data.ids.size());
    record.mode = mode == VocabularyMode::kFixed ? storage::VocabularyMode::kFixed
                                                 : storage::VocabularyMode::kSeed;
    record.extractor = data.extractor;
    record.distance_unit = toString(data.unit);
    record.settings = data.settings;
    const std::int64_t import_id = store_->recordVocabularyImport(record);

    std::vector<storage::WordRecord> rows;
    rows.reserve(data.ids.size());
    for (std::size_t i = 0; i < data.ids.size(); ++i) {
      auto word = storage::WordRecord::fromFloats(
          data.ids[i], std::nullopt, data.descriptors.ptr<float>(static_cast<int>(i)), data.dim);
      word.vocabulary_import_id = import_id;
      if (data.created_frames[i] >= 0) word.source_frame = data.created_frames[i];
      rows.push_back(std::move(word));
    }
    store_->insertWords(rows);
    if (!store_->getStateText(kMapExtractorKey))
      store_->putState(kMapExtractorKey, extractor_->signature());
    store_->putState(kVocabularyModeKey, mode == VocabularyMode::kFixed ? "fixed" : "seed");

    // The index over the imported words, grown as it will be restored: the words come from
    // the file (created frame -1, like every word whose frame is not in this map).
    vocabulary_->insert(data.ids, data.descriptors, std::vector<std::int64_t>(data.ids.size(), -1));
    vocabulary_state_.save(*store_, *vocabulary_);
    tx.commit();
  } catch (...) {
    // The transaction rolled back; RAM goes back to what the file holds.
    configure(options_);
    restoreFromStore();
    throw;
  }
  // Reopen the map's memory from the file: fixed mode, the imported words pinned in the index.
  configure(options_);
  restoreFromStore();
  return data.ids.size();
}

}  // namespace placedb
