// libFuzzer target: the image header reader (engine/src/features/image_header.h,
// placedb::readImageDimensions), which sizes PNG, JPEG, BMP, PNM, TIFF and WebP headers before
// any decoder allocates pixels. The contract: never a crash or an out-of-bounds read (ASan and
// UBSan check those), and dimensions, when given, are both > 0 (anything the reader cannot size
// must be std::nullopt so the decoder judges it).
//
// The input is copied into a buffer of exactly its size, so that a read one byte past the end
// is caught by ASan instead of landing in libFuzzer's own storage.
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>

#include "features/image_header.h"

namespace {

void check(bool ok) {
  if (!ok) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::unique_ptr<unsigned char[]> bytes(new unsigned char[size ? size : 1]);
  if (size) std::memcpy(bytes.get(), data, size);
  const auto dimensions = placedb::readImageDimensions(size ? bytes.get() : nullptr, size);
  if (dimensions) {
    check(dimensions->width > 0);
    check(dimensions->height > 0);
  }
  return 0;
}
