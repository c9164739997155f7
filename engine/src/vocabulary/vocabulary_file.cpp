#include "vocabulary/vocabulary_file.h"

#include <algorithm>
#include <boost/archive/archive_exception.hpp>
#include <boost/archive/binary_iarchive.hpp>
#include <boost/archive/binary_oarchive.hpp>
#include <boost/crc.hpp>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include "placedb/error.h"

namespace placedb::vocab {

namespace {

constexpr char kMagic[8] = {'P', 'L', 'D', 'B', 'V', 'O', 'C', '1'};
constexpr unsigned kArchiveFlags = boost::archive::no_header | boost::archive::no_codecvt;
constexpr std::uint32_t kMaxHeaderBytes = 1u << 20;
constexpr std::uint32_t kMaxStringBytes = 1u << 16;

std::uint32_t crc32Of(const std::string& bytes) {
  boost::crc_32_type crc;
  crc.process_bytes(bytes.data(), bytes.size());
  return crc.checksum();
}

void saveString(boost::archive::binary_oarchive& ar, const std::string& s) {
  const auto length = static_cast<std::uint32_t>(s.size());
  ar << length;
  ar.save_binary(s.data(), s.size());
}

// Reads from a byte string whose every length field is checked before use.
class HeaderParser {
 public:
  explicit HeaderParser(const std::string& bytes) : bytes_(bytes) {}
  template <typename T>
  T get() {
    need(sizeof(T));
    T value;
    std::memcpy(&value, bytes_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return value;
  }
  std::string getString() {
    const auto length = get<std::uint32_t>();
    if (length > kMaxStringBytes) throw std::runtime_error("header string too long");
    need(length);
    std::string s = bytes_.substr(at_, length);
    at_ += length;
    return s;
  }
  bool done() const { return at_ == bytes_.size(); }

 private:
  void need(std::size_t n) const {
    if (bytes_.size() - at_ < n) throw std::runtime_error("header is truncated");
  }
  const std::string& bytes_;
  std::size_t at_ = 0;
};

[[noreturn]] void refuse(const std::filesystem::path& path, const std::string& why) {
  throw Error(ErrorCode::kVocabularyRefused,
              "vocabulary file " + path.string() + " refused: " + why);
}

// A full disk or a file-size limit is kDiskFull, anything else kIo; `error` is the errno.
[[noreturn]] void writeFailed(const std::filesystem::path& path, const char* what, int error) {
  const bool full = error == ENOSPC || error == EFBIG || error == EDQUOT;
  throw Error(full ? ErrorCode::kDiskFull : ErrorCode::kIo,
              std::string(what) + " " + path.string() + ": " +
                  (error != 0 ? std::strerror(error) : "write failed"));
}

// Opens `path`, lets `write` fill it and reports a failed open, write, flush or close.
template <typename Write>
void writeToPath(const std::filesystem::path& path, const char* what, Write write) {
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (!file) writeFailed(path, what, errno);
  try {
    write(file);
  } catch (...) {
    std::fclose(file);
    throw;
  }
  int error = std::ferror(file) ? (errno ? errno : EIO) : 0;
  if (std::fflush(file) != 0 && error == 0) error = errno;
  if (std::fclose(file) != 0 && error == 0) error = errno;
  if (error != 0) writeFailed(path, what, error);
}

// Words as a reader may hand them on: ids unique and >= 0, every value finite. A file can pass
// its checksums and still break these (it was written by something else).
void checkWords(const std::filesystem::path& path, const VocabularyData& data) {
  std::vector<std::int64_t> ids = data.ids;
  std::sort(ids.begin(), ids.end());
  if (!ids.empty() && ids.front() < 0)
    refuse(path, "negative word id " + std::to_string(ids.front()));
  if (auto twin = std::adjacent_find(ids.begin(), ids.end()); twin != ids.end())
    refuse(path, "word id " + std::to_string(*twin) + " appears twice");
  for (int r = 0; r < data.descriptors.rows; ++r) {
    const float* row = data.descriptors.ptr<float>(r);
    for (int c = 0; c < data.descriptors.cols; ++c)
      if (!std::isfinite(row[c]))
        refuse(path, "word " + std::to_string(data.ids[std::size_t(r)]) +
                         " has a value that is not a finite number");
  }
}

void checkData(const VocabularyData& data) {
  const std::size_t n = data.ids.size();
  const bool ok =
      data.dim > 0 && data.created_frames.size() == n &&
      (n == 0 || (data.descriptors.type() == CV_32F && data.descriptors.rows == int(n) &&
                  data.descriptors.cols == data.dim));
  if (!ok) {
    throw Error(ErrorCode::kInvalidArgument,
                "vocabulary data: ids, created frames and descriptors (n x dim, CV_32F) disagree");
  }
}

std::string headerBytes(const VocabularyData& data) {
  std::ostringstream out(std::ios::binary);
  {
    boost::archive::binary_oarchive ar(out, kArchiveFlags);
    saveString(ar, data.extractor);
    const auto type = static_cast<std::uint8_t>(data.type);
    const auto dim = static_cast<std::int32_t>(data.dim);
    const auto unit = static_cast<std::uint8_t>(data.unit);
    const auto count = static_cast<std::uint64_t>(data.ids.size());
    const auto settings = static_cast<std::uint32_t>(data.settings.size());
    ar << type << dim << unit << count << settings;
    for (const auto& [key, value] : data.settings) {
      saveString(ar, key);
      saveString(ar, value);
    }
  }
  return out.str();
}

std::string payloadBytes(const VocabularyData& data) {
  const std::size_t n = data.ids.size();
  std::string bytes;
  bytes.reserve(n * (16 + 4 * std::size_t(data.dim)));
  if (n == 0) return bytes;
  bytes.append(reinterpret_cast<const char*>(data.ids.data()), n * 8);
  bytes.append(reinterpret_cast<const char*>(data.created_frames.data()), n * 8);
  for (std::size_t i = 0; i < n; ++i) {
    bytes.append(reinterpret_cast<const char*>(data.descriptors.ptr<float>(int(i))),
                 4 * std::size_t(data.dim));
  }
  return bytes;
}

constexpr const char* kRtabmapHeader = "WordID Descriptors...";
// RTAB-Map's VWDictionary::ID_START: its word 0 is ID_INVALID, so the text form numbers placedb's
// word w as w + 1, both ways.
constexpr std::int64_t kRtabmapIdStart = 1;
// The largest descriptor dimension its loader takes.
constexpr int kRtabmapMaxDimension = 1000;

// The dimension a header line `WordID Descriptors...N` announces; 0 when it has no number (the
// header RTAB-Map writes for an empty dictionary), -1 when the line is no such header.
int rtabmapHeaderDimension(std::string line) {
  while (!line.empty() && (line.back() == ' ' || line.back() == '\t' || line.back() == '\r'))
    line.pop_back();
  const std::string prefix = kRtabmapHeader;
  if (line.rfind(prefix, 0) != 0) return -1;
  const std::string digits = line.substr(prefix.size());
  if (digits.empty()) return 0;
  if (digits.size() > 6 || digits.find_first_not_of("0123456789") != std::string::npos) return -1;
  const int dim = std::stoi(digits);
  return dim > 0 ? dim : -1;
}

}  // namespace

VocabularyData snapshotOf(const Vocabulary& vocabulary) {
  VocabularyData data;
  data.extractor = vocabulary.extractorSignature();
  data.type = DescriptorType::kFloat32;
  data.dim = vocabulary.dim();
  data.unit = vocabulary.options().unit;
  data.settings = vocabulary.options().toSettings();
  data.ids = vocabulary.ids();
  data.created_frames.reserve(data.ids.size());
  data.descriptors.create(int(data.ids.size()), data.dim, CV_32F);
  for (std::size_t i = 0; i < data.ids.size(); ++i) {
    data.created_frames.push_back(vocabulary.createdFrame(data.ids[i]));
    std::memcpy(data.descriptors.ptr<float>(int(i)), vocabulary.descriptor(data.ids[i]),
                4 * std::size_t(data.dim));
  }
  return data;
}

void writeVocabularyFile(std::FILE* out, const VocabularyData& data) {
  checkData(data);
  const std::string header = headerBytes(data);
  const std::string payload = payloadBytes(data);
  std::ostringstream bytes(std::ios::binary);
  {
    boost::archive::binary_oarchive ar(bytes, kArchiveFlags);
    ar.save_binary(kMagic, sizeof(kMagic));
    const std::uint32_t version = kVocabularyFileVersion;
    const auto header_length = static_cast<std::uint32_t>(header.size());
    const std::uint32_t header_crc = crc32Of(header);
    ar << version << header_length << header_crc;
    ar.save_binary(header.data(), header.size());
    const auto payload_length = static_cast<std::uint64_t>(payload.size());
    const std::uint32_t payload_crc = crc32Of(payload);
    ar << payload_length << payload_crc;
    ar.save_binary(payload.data(), payload.size());
  }
  const std::string content = bytes.str();
  std::fwrite(content.data(), 1, content.size(), out);
}

void writeVocabularyFile(const std::filesystem::path& path, const VocabularyData& data) {
  writeToPath(path, "cannot write vocabulary file",
              [&data](std::FILE* out) { writeVocabularyFile(out, data); });
}

VocabularyData readVocabularyFile(const std::filesystem::path& path,
                                  const VocabularyExpectation& expect) {
  std::error_code ec;
  const auto file_size = std::filesystem::file_size(path, ec);
  std::ifstream file(path, std::ios::binary);
  if (ec || !file) throw Error(ErrorCode::kIo, "cannot read vocabulary file " + path.string());
  try {
    boost::archive::binary_iarchive ar(file, kArchiveFlags);
    std::uintmax_t consumed = 0;
    char magic[sizeof(kMagic)];
    if (file_size < sizeof(kMagic)) refuse(path, "truncated before the magic number");
    ar.load_binary(magic, sizeof(magic));
    if (std::memcmp(magic, kMagic, sizeof(kMagic)) != 0) refuse(path, "wrong magic number");
    std::uint32_t version = 0, header_length = 0, header_crc = 0;
    ar >> version;
    if (version != kVocabularyFileVersion) {
      refuse(path, "unsupported format version " + std::to_string(version) +
                       " (this reader: " + std::to_string(kVocabularyFileVersion) + ")");
    }
    ar >> header_length >> header_crc;
    consumed = sizeof(kMagic) + 12;
    if (header_length > kMaxHeaderBytes || header_length > file_size - consumed) {
      refuse(path, "truncated or oversized header (" + std::to_string(header_length) + " bytes)");
    }
    std::string header(header_length, '\0');
    ar.load_binary(header.data(), header_length);
    consumed += header_length;
    if (crc32Of(header) != header_crc) refuse(path, "header checksum mismatch");

    VocabularyData data;
    std::uint64_t count = 0;
    try {
      HeaderParser parse(header);
      data.extractor = parse.getString();
      data.type = static_cast<DescriptorType>(parse.get<std::uint8_t>());
      data.dim = parse.get<std::int32_t>();
      data.unit = static_cast<DistanceUnit>(parse.get<std::uint8_t>());
      count = parse.get<std::uint64_t>();
      const auto settings = parse.get<std::uint32_t>();
      for (std::uint32_t i = 0; i < settings; ++i) {
        std::string key = parse.getString();
        data.settings[key] = parse.getString();
      }
      if (!parse.done()) throw std::runtime_error("trailing bytes in the header");
    } catch (const std::runtime_error& e) {
      refuse(path, e.what());
    }
    if (!expect.extractor.empty() && data.extractor != expect.extractor) {
      refuse(path, "extractor " + data.extractor + ", map uses " + expect.extractor);
    }
    if (data.type != DescriptorType::kFloat32) refuse(path, "descriptors are not 32-bit floats");
    if (data.dim < 1 || data.dim > 4096)
      refuse(path, "invalid dimension " + std::to_string(data.dim));
    if (expect.dim != 0 && data.dim != expect.dim) {
      refuse(path,
             "dimension " + std::to_string(data.dim) + ", map uses " + std::to_string(expect.dim));
    }
    if (data.unit != DistanceUnit::kSquared && data.unit != DistanceUnit::kEuclidean) {
      refuse(path, "unknown distance unit");
    }
    if (expect.header_only) return data;
    std::uint64_t payload_length = 0;
    std::uint32_t payload_crc = 0;
    if (file_size - consumed < 12) refuse(path, "truncated before the payload");
    ar >> payload_length >> payload_crc;
    consumed += 12;
    const std::uint64_t word_bytes = 16 + 4 * std::uint64_t(data.dim);
    if (count > (file_size - consumed) / word_bytes || payload_length != count * word_bytes ||
        count > std::uint64_t(std::numeric_limits<int>::max())) {
      refuse(path, "word count " + std::to_string(count) + " does not fit the payload");
    }
    if (payload_length != file_size - consumed) {
      refuse(path, payload_length > file_size - consumed ? "truncated payload"
                                                         : "trailing bytes after the payload");
    }
    std::string payload(payload_length, '\0');
    ar.load_binary(payload.data(), payload_length);
    if (crc32Of(payload) != payload_crc) refuse(path, "payload checksum mismatch");

    const std::size_t n = count;
    data.ids.resize(n);
    data.created_frames.resize(n);
    data.descriptors.create(int(n), data.dim, CV_32F);
    if (n > 0) {  // memcpy from/to the null data() of empty vectors is undefined
      std::memcpy(data.ids.data(), payload.data(), n * 8);
      std::memcpy(data.created_frames.data(), payload.data() + n * 8, n * 8);
      std::memcpy(data.descriptors.data, payload.data() + n * 16, n * 4 * data.dim);
    }
    checkWords(path, data);
    return data;
  } catch (const Error&) {
    throw;
  } catch (const boost::archive::archive_exception& e) {
    refuse(path, std::string("unreadable archive (") + e.what() + ")");
  } catch (const std::exception& e) {
    refuse(path, e.what());
  }
}

// What RTAB-Map's loader accepts: a dimension of at most 1000 and ids its int holds.
static void checkRtabmapFits(const VocabularyData& data, const std::string& name) {
  if (data.dim > kRtabmapMaxDimension)
    throw Error(ErrorCode::kInvalidArgument,
                "cannot write " + name + " as an RTAB-Map dictionary: dimension " +
                    std::to_string(data.dim) + " (RTAB-Map reads at most " +
                    std::to_string(kRtabmapMaxDimension) + ")");
  for (const std::int64_t id : data.ids)
    if (id < 0 || id + kRtabmapIdStart > std::numeric_limits<std::int32_t>::max())
      throw Error(ErrorCode::kInvalidArgument,
                  "cannot write " + name + " as an RTAB-Map dictionary: word id " +
                      std::to_string(id) + " does not fit RTAB-Map's int ids");
}

// The rows of an RTAB-Map dictionary, for data already checked.
static void writeRtabmapRows(std::FILE* out, const VocabularyData& data) {
  // RTAB-Map takes the descriptor dimension from the number that ends its header line.
  std::fprintf(out, "%s%d\n", kRtabmapHeader, data.dim);
  for (std::size_t i = 0; i < data.ids.size() && !std::ferror(out); ++i) {
    std::fprintf(out, "%lld", static_cast<long long>(data.ids[i] + kRtabmapIdStart));
    const float* row = data.descriptors.ptr<float>(int(i));
    for (int d = 0; d < data.dim; ++d) std::fprintf(out, " %.9g", row[d]);
    std::fputc('\n', out);
  }
}

void writeVocabularyText(std::FILE* out, const VocabularyData& data, const std::string& name) {
  checkData(data);
  checkRtabmapFits(data, name);
  writeRtabmapRows(out, data);
}

void writeVocabularyText(const std::filesystem::path& path, const VocabularyData& data) {
  // Checked before the file is opened (and truncated): a refusal leaves it as it was.
  checkData(data);
  checkRtabmapFits(data, path.string());
  writeToPath(path, "cannot write vocabulary text",
              [&data](std::FILE* out) { writeRtabmapRows(out, data); });
}

VocabularyData readVocabularyText(const std::filesystem::path& path, int expected_dim) {
  std::ifstream file(path);
  if (!file) throw Error(ErrorCode::kIo, "cannot read vocabulary text " + path.string());
  VocabularyData data;
  data.dim = expected_dim;
  std::vector<float> values;
  std::string line;
  for (std::size_t line_number = 1; std::getline(file, line); ++line_number) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::string where = "line " + std::to_string(line_number) + ": ";
    if (line_number == 1 && line.rfind("WordID", 0) == 0) {
      const int header_dim = rtabmapHeaderDimension(line);
      if (header_dim < 0) refuse(path, where + "bad header (expected `WordID Descriptors...N`)");
      if (header_dim > 0 && data.dim > 0 && header_dim != data.dim) {
        refuse(path, where + "dimension " + std::to_string(header_dim) + ", expected " +
                         std::to_string(data.dim));
      }
      if (header_dim > 0) data.dim = header_dim;
      continue;
    }
    const char* at = line.c_str();
    char* end = nullptr;
    errno = 0;
    const long long id = std::strtoll(at, &end, 10);
    if (end == at || errno != 0 || id < 0) refuse(path, where + "bad word id");
    if (id < kRtabmapIdStart)
      refuse(path, where +
                       "word id 0: RTAB-Map's word ids start at 1, 0 being its invalid id "
                       "(older placedb exports started at 0: add 1 to each id)");
    std::vector<float> row;
    for (at = end;;) {
      while (*at == ' ' || *at == '\t' || *at == '\r') ++at;
      if (*at == '\0') break;
      const float v = std::strtof(at, &end);  // denormals set ERANGE yet read back exactly
      if (end == at || !std::isfinite(v)) refuse(path, where + "bad number");
      row.push_back(v);
      at = end;
    }
    if (data.dim == 0) data.dim = static_cast<int>(row.size());
    if (row.empty() || int(row.size()) != data.dim) {
      refuse(path,
             where + std::to_string(row.size()) + " values, expected " + std::to_string(data.dim));
    }
    data.ids.push_back(id - kRtabmapIdStart);
    data.created_frames.push_back(-1);
    values.insert(values.end(), row.begin(), row.end());
  }
  if (data.dim <= 0) refuse(path, "no word");
  data.descriptors = cv::Mat(int(data.ids.size()), data.dim, CV_32F);
  if (!values.empty()) std::memcpy(data.descriptors.data, values.data(), values.size() * 4);
  checkWords(path, data);
  return data;
}

}  // namespace placedb::vocab
