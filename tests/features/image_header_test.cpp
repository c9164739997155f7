// readImageDimensions / readImageFileDimensions: the size of real files written by OpenCV in every
// recognised format, hand-made headers claiming huge sizes, and malformed input that must give
// std::nullopt without crashing.
#include <gtest/gtest.h>

#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "features/image_conversion.h"
#include "features/image_header.h"
#include "test_paths.h"

namespace placedb {
namespace {

using Bytes = std::vector<unsigned char>;

std::optional<ImageDimensions> dimensionsOf(const Bytes& bytes) {
  return readImageDimensions(bytes.data(), bytes.size());
}

Bytes fileBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return Bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Width and height differ, and neither is a multiple of 8 or 16, so a swapped or rounded field
// shows.
cv::Mat testImage(int type) {
  cv::Mat image(37, 53, type);
  cv::randu(image, cv::Scalar::all(0), cv::Scalar::all(255));
  return image;
}

void appendBigEndian(Bytes& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back((v >> shift) & 0xff);
}
void appendLittleEndian(Bytes& out, std::uint32_t v, int bytes = 4) {
  for (int i = 0; i < bytes; ++i) out.push_back((v >> (8 * i)) & 0xff);
}

struct Case {
  std::string extension;
  int type;
  std::vector<int> params;
};

// Each format written by OpenCV, read back from the file and from the bytes.
TEST(ImageHeader, ReadsTheSizeOfFilesOpenCvWrites) {
  const std::vector<Case> cases = {
      {".png", CV_8UC3, {}},
      {".png", CV_16UC1, {}},
      {".jpg", CV_8UC3, {}},
      {".jpg", CV_8UC1, {cv::IMWRITE_JPEG_PROGRESSIVE, 1}},  // SOF2
      {".bmp", CV_8UC3, {}},
      {".bmp", CV_8UC1, {}},
      {".pgm", CV_8UC1, {}},
      {".pgm", CV_8UC1, {cv::IMWRITE_PXM_BINARY, 0}},  // P2, text
      {".ppm", CV_8UC3, {}},
      {".pbm", CV_8UC1, {}},
      {".tif", CV_8UC3, {}},
      {".tif", CV_16UC1, {}},
      {".webp", CV_8UC3, {cv::IMWRITE_WEBP_QUALITY, 80}},   // VP8
      {".webp", CV_8UC3, {cv::IMWRITE_WEBP_QUALITY, 101}},  // VP8L (lossless)
      {".webp", CV_8UC4, {cv::IMWRITE_WEBP_QUALITY, 80}},   // VP8X (alpha)
  };
  const auto dir = testing::scratchDir("ImageHeaderFormats");
  int index = 0;
  for (const auto& c : cases) {
    SCOPED_TRACE(c.extension + " case " + std::to_string(index));
    const auto path = dir / ("image" + std::to_string(index++) + c.extension);
    if (!cv::haveImageWriter(path.string())) {
      std::cout << "[ SKIPPED  ] OpenCV here cannot write " << c.extension << "\n";
      continue;
    }
    const cv::Mat image = testImage(c.type);
    ASSERT_TRUE(cv::imwrite(path.string(), image, c.params));
    const auto from_file = readImageFileDimensions(path.string());
    ASSERT_TRUE(from_file.has_value());
    EXPECT_EQ(from_file->width, 53u);
    EXPECT_EQ(from_file->height, 37u);
    const auto from_bytes = dimensionsOf(fileBytes(path));
    ASSERT_TRUE(from_bytes.has_value());
    EXPECT_EQ(from_bytes->width, 53u);
    EXPECT_EQ(from_bytes->height, 37u);
  }
}

TEST(ImageHeader, WebpIsReadWhenOpenCvCanWriteIt) {
  if (!cv::haveImageWriter("x.webp")) GTEST_SKIP() << "OpenCV here was built without WebP";
  std::vector<uchar> bytes;
  ASSERT_TRUE(cv::imencode(".webp", testImage(CV_8UC3), bytes));
  const auto size = readImageDimensions(bytes.data(), bytes.size());
  ASSERT_TRUE(size.has_value());
  EXPECT_EQ(size->width, 53u);
  EXPECT_EQ(size->height, 37u);
}

// Every prefix of every real header, and random bytes behind each format's magic: never a crash,
// and a prefix too short to hold the size gives nullopt.
TEST(ImageHeader, TruncatedAndRandomHeadersGiveNulloptWithoutCrashing) {
  std::mt19937 rng(7);
  for (const char* extension : {".png", ".jpg", ".bmp", ".pgm", ".tif", ".webp"}) {
    SCOPED_TRACE(extension);
    if (!cv::haveImageWriter(std::string("x") + extension)) continue;
    std::vector<uchar> encoded;
    ASSERT_TRUE(cv::imencode(extension, testImage(CV_8UC1), encoded));
    const Bytes bytes(encoded.begin(), encoded.end());
    // Too short for any format's size; from the first prefix that holds the size on, every
    // longer one gives it too, exactly.
    bool found = false;
    for (std::size_t keep = 0; keep <= bytes.size(); ++keep) {
      SCOPED_TRACE(keep);
      const auto size = dimensionsOf(Bytes(bytes.begin(), bytes.begin() + keep));
      if (keep < 8) {
        EXPECT_FALSE(size.has_value());
      }
      if (found) {
        EXPECT_TRUE(size.has_value());
      }
      if (!size) continue;
      found = true;
      EXPECT_EQ(size->width, 53u);
      EXPECT_EQ(size->height, 37u);
    }
    EXPECT_TRUE(found);
    for (int trial = 0; trial < 200; ++trial) {
      Bytes noisy(bytes.begin(), bytes.begin() + std::min<std::size_t>(bytes.size(), 4));
      for (int i = 0; i < 300; ++i) noisy.push_back(static_cast<unsigned char>(rng()));
      dimensionsOf(noisy);
    }
  }
  for (int trial = 0; trial < 1000; ++trial) {
    Bytes noise(rng() % 600);
    for (auto& b : noise) b = static_cast<unsigned char>(rng());
    dimensionsOf(noise);
  }
  EXPECT_FALSE(readImageDimensions(nullptr, 0).has_value());
  EXPECT_FALSE(readImageFileDimensions("/nonexistent/image.png").has_value());
}

TEST(ImageHeader, UnknownOrMalformedHeadersGiveNullopt) {
  const auto text = [](const std::string& s) { return Bytes(s.begin(), s.end()); };
  EXPECT_FALSE(dimensionsOf(text("frame_index,path\n0,a.png\n")).has_value());
  EXPECT_FALSE(dimensionsOf(text("P6 640")).has_value());            // height cut off
  EXPECT_FALSE(dimensionsOf(text("P7\nWIDTH 4\n")).has_value());     // PAM: not handled
  EXPECT_FALSE(dimensionsOf(text("P6x640 480 255\n")).has_value());  // no separator
  // A JPEG reaching its scan data without a frame header.
  EXPECT_FALSE(dimensionsOf(Bytes{0xFF, 0xD8, 0xFF, 0xDA, 0x00, 0x08, 0, 0, 0, 0}).has_value());
  // A JPEG whose segment lengths are all zero: refused, not looped on.
  EXPECT_FALSE(dimensionsOf(Bytes{0xFF, 0xD8, 0xFF, 0xE0, 0x00, 0x00, 0xFF, 0xC0}).has_value());
  // A TIFF whose first directory lies past the end.
  EXPECT_FALSE(dimensionsOf(Bytes{'I', 'I', '*', 0, 0xFF, 0xFF, 0xFF, 0x7F}).has_value());
}

TEST(ImageHeader, PnmCommentsAndHugeNumbers) {
  const std::string pgm = "P5\n# made by hand\n#another\n  640 # width\n480\n255\n";
  const auto size = dimensionsOf(Bytes(pgm.begin(), pgm.end()));
  ASSERT_TRUE(size.has_value());
  EXPECT_EQ(size->width, 640u);
  EXPECT_EQ(size->height, 480u);
  const std::string huge = "P4 99999999999999999999 2\n";
  const auto saturated = dimensionsOf(Bytes(huge.begin(), huge.end()));
  ASSERT_TRUE(saturated.has_value());
  EXPECT_EQ(saturated->width, 0xFFFFFFFFu);
  EXPECT_FALSE(withinImageLimits(*saturated));
}

TEST(ImageHeader, HandMadeHugePngAndBmpHeadersAreReadAsTheyClaim) {
  Bytes png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  appendBigEndian(png, 13);
  png.insert(png.end(), {'I', 'H', 'D', 'R'});
  appendBigEndian(png, 20000);
  appendBigEndian(png, 20000);
  png.insert(png.end(), {1, 0, 0, 0, 0});  // no CRC, no data: only the header is read

  Bytes bmp = {'B', 'M'};
  appendLittleEndian(bmp, 0);   // file size (unchecked)
  appendLittleEndian(bmp, 0);   // reserved
  appendLittleEndian(bmp, 54);  // pixel data offset
  appendLittleEndian(bmp, 40);  // BITMAPINFOHEADER
  appendLittleEndian(bmp, 20000);
  appendLittleEndian(bmp, static_cast<std::uint32_t>(-20000));  // negative: top-down rows
  appendLittleEndian(bmp, 1, 2);                                // planes
  appendLittleEndian(bmp, 24, 2);                               // bits per pixel

  Bytes core_bmp = {'B', 'M', 0, 0, 0, 0, 0, 0, 0, 0, 26, 0, 0, 0};
  appendLittleEndian(core_bmp, 12);  // BITMAPCOREHEADER: 16-bit sizes
  appendLittleEndian(core_bmp, 20000, 2);
  appendLittleEndian(core_bmp, 20000, 2);
  appendLittleEndian(core_bmp, 1, 2);
  appendLittleEndian(core_bmp, 24, 2);

  for (const Bytes* header : {&png, &bmp, &core_bmp}) {
    const auto size = dimensionsOf(*header);
    ASSERT_TRUE(size.has_value());
    EXPECT_EQ(size->width, 20000u);
    EXPECT_EQ(size->height, 20000u);
    EXPECT_FALSE(withinImageLimits(*size));
  }
}

// Layouts OpenCV's writers do not produce here: a big-endian TIFF with SHORT width and LONG
// height, a little-endian BigTIFF, and a JPEG whose frame header follows a DHT (C4) segment and
// fill bytes.
TEST(ImageHeader, HandMadeTiffAndJpegLayouts) {
  Bytes tiff = {'M', 'M', 0, 42};
  appendBigEndian(tiff, 8);                     // first IFD right after the header
  tiff.insert(tiff.end(), {0, 3});              // three entries
  tiff.insert(tiff.end(), {0x01, 0x03, 0, 3});  // tag 259 (compression), ignored
  appendBigEndian(tiff, 1);
  tiff.insert(tiff.end(), {0, 1, 0, 0});
  tiff.insert(tiff.end(), {0x01, 0x00, 0, 3});  // tag 256, SHORT, left-justified
  appendBigEndian(tiff, 1);
  tiff.insert(tiff.end(), {0x4E, 0x20, 0, 0});  // 20000
  tiff.insert(tiff.end(), {0x01, 0x01, 0, 4});  // tag 257, LONG
  appendBigEndian(tiff, 1);
  appendBigEndian(tiff, 300);

  Bytes big_tiff = {'I', 'I', 43, 0, 8, 0, 0, 0};
  appendLittleEndian(big_tiff, 16);  // first IFD, 64-bit offset
  appendLittleEndian(big_tiff, 0);
  appendLittleEndian(big_tiff, 2);  // two entries, 64-bit count
  appendLittleEndian(big_tiff, 0);
  for (std::uint32_t tag : {256u, 257u}) {
    appendLittleEndian(big_tiff, tag, 2);
    appendLittleEndian(big_tiff, tag == 256 ? 16 : 4, 2);  // LONG8, then LONG
    appendLittleEndian(big_tiff, 1);
    appendLittleEndian(big_tiff, 0);
    appendLittleEndian(big_tiff, tag == 256 ? 20000 : 300);
    appendLittleEndian(big_tiff, 0);
  }

  Bytes jpeg = {0xFF, 0xD8, 0xFF, 0xC4, 0x00, 0x04, 0xAA, 0xBB, 0xFF, 0xFF, 0xFF, 0xC1,
                0x00, 0x0B, 0x08, 0x01, 0x2C, 0x4E, 0x20, 0x01, 0x01, 0x11, 0x00};

  for (const Bytes* header : {&tiff, &big_tiff, &jpeg}) {
    const auto size = dimensionsOf(*header);
    ASSERT_TRUE(size.has_value());
    EXPECT_EQ(size->width, 20000u);
    EXPECT_EQ(size->height, 300u);
  }
}

// What the fuzzer found (fuzz/corpus/image_header): a zero side is no size at all, and a TIFF
// directory with no entries is read without touching memory.
TEST(ImageHeader, ZeroSidesAndEmptyTiffDirectoriesGiveNullopt) {
  Bytes bmp = {'B', 'M'};
  appendLittleEndian(bmp, 0);
  appendLittleEndian(bmp, 0);
  appendLittleEndian(bmp, 54);
  appendLittleEndian(bmp, 40);
  appendLittleEndian(bmp, 8);
  appendLittleEndian(bmp, 0);  // height 0
  appendLittleEndian(bmp, 1, 2);
  appendLittleEndian(bmp, 24, 2);
  EXPECT_FALSE(dimensionsOf(bmp).has_value());

  Bytes png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  appendBigEndian(png, 13);
  png.insert(png.end(), {'I', 'H', 'D', 'R'});
  appendBigEndian(png, 0);  // width 0
  appendBigEndian(png, 8);
  png.insert(png.end(), {8, 0, 0, 0, 0});
  EXPECT_FALSE(dimensionsOf(png).has_value());

  Bytes tiff = {'I', 'I', 42, 0};
  appendLittleEndian(tiff, 8);
  appendLittleEndian(tiff, 0, 2);  // a directory of no entries
  appendLittleEndian(tiff, 0);     // and no next one
  EXPECT_FALSE(dimensionsOf(tiff).has_value());
}

TEST(ImageHeader, LimitsAreSixteenThousandPixelsASideAndFortyMegapixels) {
  EXPECT_TRUE(withinImageLimits({7680, 4320}));  // 8K UHD
  EXPECT_TRUE(withinImageLimits({16384, 2000}));
  EXPECT_FALSE(withinImageLimits({16385, 100}));
  EXPECT_FALSE(withinImageLimits({100, 16385}));
  EXPECT_FALSE(withinImageLimits({8000, 5001}));  // 40.008 MP
  EXPECT_TRUE(withinImageLimits({8000, 5000}));
  EXPECT_EQ(imageLimitProblem({20000, 20000}),
            "20000 x 20000 pixels; the limit is 16384 pixels a side and 40 megapixels");
}

}  // namespace
}  // namespace placedb
