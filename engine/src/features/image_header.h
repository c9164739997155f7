#pragma once
// Width and height of an image read from its header, without decoding it: lets callers refuse an
// image whose pixels would not fit in memory before OpenCV allocates them.
//
// Recognised: PNG (IHDR), JPEG (first SOFn), BMP (core and info headers), PNM (P1-P6), TIFF
// (first IFD, both byte orders) and WebP (VP8, VP8L, VP8X). Anything else, or a header that does
// not parse, gives std::nullopt: the caller then lets the decoder judge the file as before, so
// an image is never refused only because this reader did not understand it.
//
// Every read is bounded (a few kilobytes at chosen offsets, a bounded number of JPEG segments and
// TIFF entries): a malformed or hostile header costs little and never loops.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

namespace placedb {

struct ImageDimensions {
  std::uint32_t width = 0;
  std::uint32_t height = 0;
};

// Reads the header of an in-memory encoded image.
std::optional<ImageDimensions> readImageDimensions(const unsigned char* data, std::size_t size);

// Reads the header of the file at `path`; std::nullopt too when it cannot be opened.
std::optional<ImageDimensions> readImageFileDimensions(const std::string& path);

}  // namespace placedb
