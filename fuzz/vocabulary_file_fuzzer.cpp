// libFuzzer target: the vocabulary file readers (binary and RTAB-Map text form).
//
// The first input byte picks the reader: 0 mod 3 the binary reader on the bytes as given, 1 the
// binary reader after the two CRC-32 fields are recomputed (otherwise nearly every mutation stops
// at the checksum and the header and payload parsers are never reached), 2 the text reader.
// The contract: a placedb::Error or a result whose parts agree; anything else is a crash.
#include <unistd.h>
#include <boost/crc.hpp>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>

#include "placedb/error.h"
#include "vocabulary/vocabulary_file.h"

namespace {

// Offsets of the binary layout (see vocabulary_file.h).
constexpr std::size_t kHeaderLengthAt = 12, kHeaderCrcAt = 16, kHeaderAt = 20;

std::uint32_t crcOf(const char* data, std::size_t size) {
  boost::crc_32_type crc;
  crc.process_bytes(data, size);
  return crc.checksum();
}

void fixChecksums(std::string& bytes) {
  if (bytes.size() < kHeaderAt) return;
  std::uint32_t header_length = 0;
  std::memcpy(&header_length, bytes.data() + kHeaderLengthAt, 4);
  if (header_length > bytes.size() - kHeaderAt) return;
  const std::uint32_t header_crc = crcOf(bytes.data() + kHeaderAt, header_length);
  std::memcpy(&bytes[kHeaderCrcAt], &header_crc, 4);
  const std::size_t payload_fields = kHeaderAt + header_length;  // u64 length, u32 crc
  if (bytes.size() < payload_fields + 12) return;
  const std::size_t payload_at = payload_fields + 12;
  const std::uint32_t payload_crc = crcOf(bytes.data() + payload_at, bytes.size() - payload_at);
  std::memcpy(&bytes[payload_fields + 8], &payload_crc, 4);
}

const std::string& scratchPath() {
  static const std::string path =
      (std::getenv("TMPDIR") ? std::string(std::getenv("TMPDIR")) : std::string("/tmp")) +
      "/placedb-fuzz-vocabulary-" + std::to_string(getpid());
  return path;
}

void check(bool ok) {
  if (!ok) std::abort();
}

void checkConsistent(const placedb::vocab::VocabularyData& d) {
  const auto n = d.ids.size();
  check(d.created_frames.size() == n);
  check(d.descriptors.empty() ? n == 0 || d.dim == 0
                              : static_cast<std::size_t>(d.descriptors.rows) == n &&
                                    d.descriptors.cols == d.dim && d.descriptors.type() == CV_32F);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const int mode = data[0] % 3;
  std::string bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  if (mode == 1) fixChecksums(bytes);
  {
    std::ofstream out(scratchPath(), std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }
  try {
    auto result = mode == 2 ? placedb::vocab::readVocabularyText(scratchPath())
                            : placedb::vocab::readVocabularyFile(scratchPath());
    checkConsistent(result);
  } catch (const placedb::Error& e) {
    // A refusal must say which file it refused.
    check(std::string(e.what()).find(scratchPath()) != std::string::npos);
  }
  return 0;
}
