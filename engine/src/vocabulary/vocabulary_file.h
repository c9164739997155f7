#pragma once
// The vocabulary file: a Boost.Serialization binary archive (no archive header, so the bytes do not
// depend on the Boost version) laid out as
//   magic "PLDBVOC1" (8 bytes) | u32 format version
//   u32 header length | u32 CRC-32 of the header | header
//       header = extractor, descriptor type, dimension, distance unit, word count,
//                settings (sorted key/value strings)
//   u64 payload length | u32 CRC-32 of the payload | payload
//       payload = word ids (i64 x n), created frames (i64 x n), descriptors (f32 x n x dim,
//       row-major)
// Integers are the machine's (little-endian on every supported target). The reader refuses in
// that order -- magic, version, header size/checksum, extractor, type, dimension, payload size
// against the file length, payload checksum -- before allocating anything sized by the file, so a
// damaged file costs at most its own length. Same content gives byte-identical files: there is
// no timestamp anywhere.
//
// The text form is RTAB-Map's dictionary (VWDictionary::exportDictionary, and what its fixed
// dictionary loader reads): a header line `WordID Descriptors...N` giving the dimension, then one
// word a line, "WordID d1 ... dN", single spaces. Its word ids start at 1 (RTAB-Map's
// VWDictionary::ID_START; 0 is its invalid id): placedb's word w is written as w + 1 and read
// back as w, so an RTAB-Map file's first word becomes placedb's word 0 and export -> import ->
// export gives the same file. A word id 0 is refused. placedb writes the floats in %.9g so that
// they read back bit for bit (RTAB-Map's own %f files read too). It holds no created frames (read
// back as -1). The reader also takes files without the header line, the dimension then being
// the first line's.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "features/features.h"
#include "vocabulary/vocabulary.h"

namespace placedb::vocab {

constexpr std::uint32_t kVocabularyFileVersion = 1;

struct VocabularyData {
  std::string extractor;
  DescriptorType type = DescriptorType::kFloat32;
  int dim = 0;
  DistanceUnit unit = DistanceUnit::kSquared;
  std::map<std::string, std::string> settings;
  std::vector<std::int64_t> ids;
  std::vector<std::int64_t> created_frames;
  cv::Mat descriptors;  // ids.size() x dim, CV_32F
};

// What the reader insists on; empty extractor / zero dimension accept any. header_only stops
// after the header (checked, checksum included): the words stay empty and the payload unread.
struct VocabularyExpectation {
  std::string extractor;
  int dim = 0;
  bool header_only = false;
};

// The words in RAM, ascending ids, with the vocabulary's settings.
VocabularyData snapshotOf(const Vocabulary& vocabulary);

// Throws placedb::Error(kIo) when the file cannot be written, kInvalidArgument on inconsistent
// data. The stream forms write to `out` and leave its errors on its error flag (the command
// line's one writer, tools/src/whole_file.h, checks them).
void writeVocabularyFile(const std::filesystem::path& path, const VocabularyData& data);
void writeVocabularyFile(std::FILE* out, const VocabularyData& data);
// Throws placedb::Error(kVocabularyRefused) naming the file and the reason, kIo if unreadable.
VocabularyData readVocabularyFile(const std::filesystem::path& path,
                                  const VocabularyExpectation& expect = {});

// RTAB-Map's text dictionary. Data RTAB-Map cannot load (a dimension over 1000, an id its int
// cannot hold) is refused with kInvalidArgument naming the file (`name` for a stream) before a
// byte is written.
void writeVocabularyText(const std::filesystem::path& path, const VocabularyData& data);
void writeVocabularyText(std::FILE* out, const VocabularyData& data,
                         const std::string& name = "the output");
// expected_dim 0: taken from the header (or the first word). Throws kVocabularyRefused on a
// malformed line or a dimension that differs from expected_dim or the header.
VocabularyData readVocabularyText(const std::filesystem::path& path, int expected_dim = 0);

}  // namespace placedb::vocab
