#include "features/image_header.h"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <fstream>
#include <limits>
#include <vector>

namespace placedb {
namespace {

// JPEG segments (and 0xFF fill bytes) walked before giving up: real files put the frame header
// after a handful of APPn/DQT segments.
constexpr int kMaxJpegSteps = 4096;
// PNM headers are text with comments of any length; past this the decoder judges the file.
constexpr std::size_t kMaxPnmHeaderBytes = 64 * 1024;
// A TIFF directory has at most 65535 entries; BigTIFF counts are 64-bit, so cap them alike.
constexpr std::uint64_t kMaxTiffEntries = 65535;

// Random access to the encoded bytes, so that the file case reads only the few places that
// matter (a TIFF's first directory is often written at the end of the file).
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  // Copies up to `n` bytes at `offset` into `out`; returns how many were available.
  virtual std::size_t read(std::uint64_t offset, unsigned char* out, std::size_t n) = 0;
  bool readExact(std::uint64_t offset, unsigned char* out, std::size_t n) {
    return read(offset, out, n) == n;
  }
};

class MemorySource final : public ByteSource {
 public:
  MemorySource(const unsigned char* data, std::size_t size) : data_(data), size_(size) {}
  std::size_t read(std::uint64_t offset, unsigned char* out, std::size_t n) override {
    // n == 0 too: `out` is then often an empty vector's data(), a null pointer, and memcpy with
    // a null pointer is undefined even for 0 bytes (fuzz_image_header: a TIFF IFD of 0 entries).
    if (offset >= size_ || n == 0) return 0;
    const auto count = static_cast<std::size_t>(std::min<std::uint64_t>(n, size_ - offset));
    std::memcpy(out, data_ + offset, count);
    return count;
  }

 private:
  const unsigned char* data_;
  std::size_t size_;
};

class FileSource final : public ByteSource {
 public:
  explicit FileSource(const std::string& path) : in_(path, std::ios::binary) {}
  bool isOpen() const { return in_.is_open(); }
  std::size_t read(std::uint64_t offset, unsigned char* out, std::size_t n) override {
    if (offset > static_cast<std::uint64_t>(std::numeric_limits<std::streamoff>::max())) return 0;
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(offset));
    if (!in_) return 0;
    in_.read(reinterpret_cast<char*>(out), static_cast<std::streamsize>(n));
    return static_cast<std::size_t>(in_.gcount());
  }

 private:
  std::ifstream in_;
};

std::uint32_t be16(const unsigned char* p) { return std::uint32_t(p[0]) << 8 | p[1]; }
std::uint32_t le16(const unsigned char* p) { return std::uint32_t(p[1]) << 8 | p[0]; }
std::uint32_t le24(const unsigned char* p) { return le16(p) | std::uint32_t(p[2]) << 16; }
std::uint32_t be32(const unsigned char* p) { return be16(p) << 16 | be16(p + 2); }
std::uint32_t le32(const unsigned char* p) { return le16(p + 2) << 16 | le16(p); }

bool startsWith(const unsigned char* head, std::size_t n, const char* magic, std::size_t length) {
  return n >= length && std::memcmp(head, magic, length) == 0;
}

// Signature (8 bytes), then the IHDR chunk's length and type, then width and height.
std::optional<ImageDimensions> pngDimensions(const unsigned char* head, std::size_t n) {
  if (n < 24 || std::memcmp(head + 12, "IHDR", 4) != 0) return std::nullopt;
  return ImageDimensions{be32(head + 16), be32(head + 20)};
}

// SOF0..SOF15 carry the frame size; C4 (DHT), C8 (JPG) and CC (DAC) share the range but not that.
bool isFrameHeader(unsigned marker) {
  return marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
}

std::optional<ImageDimensions> jpegDimensions(ByteSource& source) {
  std::uint64_t pos = 2;  // after SOI
  for (int step = 0; step < kMaxJpegSteps; ++step) {
    unsigned char m[2];
    if (!source.readExact(pos, m, 2) || m[0] != 0xFF) return std::nullopt;
    const unsigned marker = m[1];
    if (marker == 0xFF) {  // fill byte before the marker
      ++pos;
      continue;
    }
    pos += 2;
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD8))
      continue;  // TEM, RSTn, SOI: no length
    // Scan data or the end before any frame header: not a JPEG this reader understands.
    if (marker == 0x00 || marker == 0xD9 || marker == 0xDA) return std::nullopt;
    unsigned char segment[7];
    if (!source.readExact(pos, segment, 2)) return std::nullopt;
    const std::uint32_t length = be16(segment);  // counts its own two bytes
    if (length < 2) return std::nullopt;
    if (isFrameHeader(marker)) {
      // Length, precision, height, width. Height 0 means "given later by DNL": leave it to libjpeg.
      if (length < 7 || !source.readExact(pos, segment, 7)) return std::nullopt;
      const std::uint32_t height = be16(segment + 3);
      if (height == 0) return std::nullopt;
      return ImageDimensions{be16(segment + 5), height};
    }
    pos += length;
  }
  return std::nullopt;
}

// BITMAPFILEHEADER (14 bytes), then the DIB header starting with its own size. The core header
// (12 bytes) has 16-bit sizes; the info header and its successors (up to V5, 124 bytes) have
// 32-bit signed ones, a negative height meaning top-down rows. 36..39 are accepted like OpenCV.
std::optional<ImageDimensions> bmpDimensions(const unsigned char* head, std::size_t n) {
  if (n < 26) return std::nullopt;
  const std::uint32_t header_size = le32(head + 14);
  if (header_size == 12) return ImageDimensions{le16(head + 18), le16(head + 20)};
  if (header_size < 36 || header_size > 124) return std::nullopt;
  const auto width = static_cast<std::int32_t>(le32(head + 18));
  const auto height = static_cast<std::int64_t>(static_cast<std::int32_t>(le32(head + 22)));
  if (width < 0) return std::nullopt;
  return ImageDimensions{static_cast<std::uint32_t>(width),
                         static_cast<std::uint32_t>(height < 0 ? -height : height)};
}

// "P1".."P6", then width and height as decimal text separated by whitespace and '#' comments
// (to the end of the line). Numbers too large for 32 bits saturate: they are still "too large".
std::optional<ImageDimensions> pnmDimensions(ByteSource& source) {
  std::vector<unsigned char> text(kMaxPnmHeaderBytes);
  const std::size_t n = source.read(0, text.data(), text.size());
  std::size_t pos = 2;
  if (pos >= n || !(std::isspace(text[pos]) || text[pos] == '#')) return std::nullopt;
  std::uint32_t values[2] = {0, 0};
  for (std::uint32_t& value : values) {
    while (pos < n && (std::isspace(text[pos]) || text[pos] == '#')) {
      if (text[pos] != '#') {
        ++pos;
        continue;
      }
      while (pos < n && text[pos] != '\n' && text[pos] != '\r') ++pos;
    }
    if (pos >= n || !std::isdigit(text[pos])) return std::nullopt;
    std::uint64_t number = 0;
    for (; pos < n && std::isdigit(text[pos]); ++pos)
      number = std::min<std::uint64_t>(number * 10 + (text[pos] - '0'), 0xFFFFFFFFu);
    if (pos >= n) return std::nullopt;  // the number may go on past what was read
    value = static_cast<std::uint32_t>(number);
  }
  return ImageDimensions{values[0], values[1]};
}

// Classic TIFF: 8-byte header with the first IFD's 32-bit offset; 2-byte entry count; 12-byte
// entries (tag, type, count, value). BigTIFF: 16-byte header, 64-bit offsets and counts, 20-byte
// entries. Width is tag 256, height 257, as SHORT (3), LONG (4) or, in BigTIFF, LONG8 (16).
std::optional<ImageDimensions> tiffDimensions(ByteSource& source, const unsigned char* head,
                                              std::size_t n, bool big_endian, bool big_tiff) {
  const auto u16 = [&](const unsigned char* p) { return big_endian ? be16(p) : le16(p); };
  const auto u32 = [&](const unsigned char* p) { return big_endian ? be32(p) : le32(p); };
  const auto u64 = [&](const unsigned char* p) -> std::uint64_t {
    const std::uint64_t a = u32(p), b = u32(p + 4);
    return big_endian ? a << 32 | b : b << 32 | a;
  };
  if (n < (big_tiff ? 16u : 8u)) return std::nullopt;
  if (big_tiff && (u16(head + 4) != 8 || u16(head + 6) != 0)) return std::nullopt;
  const std::uint64_t ifd = big_tiff ? u64(head + 8) : u32(head + 4);
  const std::size_t count_size = big_tiff ? 8 : 2, entry_size = big_tiff ? 20 : 12;
  unsigned char count_bytes[8];
  if (ifd > std::numeric_limits<std::uint64_t>::max() - count_size ||
      !source.readExact(ifd, count_bytes, count_size))
    return std::nullopt;
  const std::uint64_t count =
      std::min(big_tiff ? u64(count_bytes) : std::uint64_t(u16(count_bytes)), kMaxTiffEntries);
  std::vector<unsigned char> entries(static_cast<std::size_t>(count) * entry_size);
  const std::size_t got = source.read(ifd + count_size, entries.data(), entries.size());
  std::optional<std::uint64_t> width, height;
  for (std::size_t at = 0; at + entry_size <= got; at += entry_size) {
    const unsigned char* entry = entries.data() + at;
    const std::uint32_t tag = u16(entry), type = u16(entry + 2);
    const std::uint64_t values = big_tiff ? u64(entry + 4) : u32(entry + 4);
    const unsigned char* value = entry + (big_tiff ? 12 : 8);  // left-justified in both orders
    if ((tag != 256 && tag != 257) || values < 1) continue;
    std::optional<std::uint64_t> number;
    if (type == 3) number = u16(value);
    if (type == 4) number = u32(value);
    if (type == 16 && big_tiff) number = u64(value);
    if (number) (tag == 256 ? width : height) = number;
  }
  if (!width || !height) return std::nullopt;
  const auto clamp = [](std::uint64_t v) {
    return static_cast<std::uint32_t>(std::min<std::uint64_t>(v, 0xFFFFFFFFu));
  };
  return ImageDimensions{clamp(*width), clamp(*height)};
}

// "RIFF", size, "WEBP", then the first chunk's FourCC and size; its payload starts at byte 20.
std::optional<ImageDimensions> webpDimensions(const unsigned char* head, std::size_t n) {
  if (n < 30) return std::nullopt;
  const unsigned char* chunk = head + 12;
  const unsigned char* payload = head + 20;
  if (std::memcmp(chunk, "VP8 ", 4) == 0) {
    // Lossy: 3-byte frame tag, start code 9D 01 2A, then 14-bit width and height (2 bits scale).
    if (payload[3] != 0x9D || payload[4] != 0x01 || payload[5] != 0x2A) return std::nullopt;
    return ImageDimensions{le16(payload + 6) & 0x3FFF, le16(payload + 8) & 0x3FFF};
  }
  if (std::memcmp(chunk, "VP8L", 4) == 0) {
    // Lossless: signature 0x2F, then width-1 and height-1 in 14 bits each, little-endian bits.
    if (payload[0] != 0x2F) return std::nullopt;
    const std::uint32_t bits = le32(payload + 1);
    return ImageDimensions{(bits & 0x3FFF) + 1, ((bits >> 14) & 0x3FFF) + 1};
  }
  if (std::memcmp(chunk, "VP8X", 4) == 0) {
    // Extended: 4 bytes of flags, then canvas width-1 and height-1 in 24 bits each.
    return ImageDimensions{le24(payload + 4) + 1, le24(payload + 7) + 1};
  }
  return std::nullopt;
}

std::optional<ImageDimensions> headerDimensions(ByteSource& source) {
  unsigned char head[32] = {};
  const std::size_t n = source.read(0, head, sizeof head);
  if (startsWith(head, n, "\x89PNG\r\n\x1a\n", 8)) return pngDimensions(head, n);
  if (startsWith(head, n, "\xFF\xD8\xFF", 3)) return jpegDimensions(source);
  if (startsWith(head, n, "BM", 2)) return bmpDimensions(head, n);
  if (n >= 2 && head[0] == 'P' && head[1] >= '1' && head[1] <= '6') return pnmDimensions(source);
  if (startsWith(head, n, "II*\0", 4)) return tiffDimensions(source, head, n, false, false);
  if (startsWith(head, n, "MM\0*", 4)) return tiffDimensions(source, head, n, true, false);
  if (startsWith(head, n, "II+\0", 4)) return tiffDimensions(source, head, n, false, true);
  if (startsWith(head, n, "MM\0+", 4)) return tiffDimensions(source, head, n, true, true);
  if (startsWith(head, n, "RIFF", 4) && n >= 12 && std::memcmp(head + 8, "WEBP", 4) == 0)
    return webpDimensions(head, n);
  return std::nullopt;
}

// A zero width or height is no size this reader can vouch for: give std::nullopt so the decoder
// judges the file, as for any header that does not parse, and callers never see a 0 side. Every
// format's header can hold one (fuzz_image_header found a BMP with height 0; PNG, JPEG, PNM, TIFF
// and WebP ones are as easy to write), so the check is made once here for all of them.
std::optional<ImageDimensions> readDimensions(ByteSource& source) {
  const std::optional<ImageDimensions> size = headerDimensions(source);
  if (size && (size->width == 0 || size->height == 0)) return std::nullopt;
  return size;
}

}  // namespace

std::optional<ImageDimensions> readImageDimensions(const unsigned char* data, std::size_t size) {
  MemorySource source(data, data ? size : 0);
  return readDimensions(source);
}

std::optional<ImageDimensions> readImageFileDimensions(const std::string& path) {
  FileSource source(path);
  if (!source.isOpen()) return std::nullopt;
  return readDimensions(source);
}

}  // namespace placedb
