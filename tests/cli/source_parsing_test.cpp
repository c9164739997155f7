// How `placedb map` turns a SOURCE into frames: natural order, list files, unreadable images.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "file_bytes.h"
#include "placedb/error.h"
#include "sources/image_source.h"
#include "test_paths.h"

namespace placedb::cli {
namespace {

namespace fs = std::filesystem;
using placedb::testing::scratchDir;

using placedb::testing::writeBytes;

cv::Mat pattern() {
  cv::Mat image(48, 64, CV_8UC3);
  cv::randu(image, 0, 255);
  return image;
}

TEST(NaturalOrder, NumbersCompareByValue) {
  std::vector<std::string> names = {"10.jpg",     "2.jpg",    "1.jpg",   "img12b.png",
                                    "img12a.png", "img3.png", "001.jpg", "a.jpg"};
  std::sort(names.begin(), names.end(), naturalLess);
  std::vector<std::string> expected = {"1.jpg", "001.jpg",  "2.jpg",      "10.jpg",
                                       "a.jpg", "img3.png", "img12a.png", "img12b.png"};
  EXPECT_EQ(names, expected);
}

TEST(NaturalOrder, IsAStrictWeakOrder) {
  EXPECT_FALSE(naturalLess("5.jpg", "5.jpg"));
  EXPECT_TRUE(naturalLess("frame9", "frame10"));
  EXPECT_FALSE(naturalLess("frame10", "frame9"));
  EXPECT_TRUE(naturalLess("x", "x1"));
  // Runs longer than any integer type still compare by value.
  EXPECT_TRUE(naturalLess("99999999999999999999999", "100000000000000000000000"));
}

TEST(ImageFolder, NaturalOrderAndNonImagesSkipped) {
  auto dir = scratchDir("ImageFolder_natural");
  for (const char* name : {"10.jpg", "2.jpg", "1.PNG"})
    cv::imwrite((dir / name).string(), pattern());
  writeBytes(dir / "notes.txt", "not an image");
  fs::create_directories(dir / "sub");
  std::vector<std::string> images, skipped;
  listImageFolder(dir, images, skipped);
  ASSERT_EQ(images.size(), 3u);
  EXPECT_EQ(fs::path(images[0]).filename(), "1.PNG");
  EXPECT_EQ(fs::path(images[1]).filename(), "2.jpg");
  EXPECT_EQ(fs::path(images[2]).filename(), "10.jpg");
  ASSERT_EQ(skipped.size(), 1u);
  EXPECT_EQ(fs::path(skipped[0]).filename(), "notes.txt");

  auto source = ImageSource::open(dir.string());
  EXPECT_EQ(source->kind(), "folder");
  EXPECT_EQ(source->size(), 3);
  source->seek(1);
  SourceFrame frame;
  ASSERT_TRUE(source->read(frame));
  EXPECT_EQ(frame.index, 1);
  EXPECT_FALSE(frame.image.empty());
  ASSERT_TRUE(source->read(frame));
  EXPECT_EQ(frame.index, 2);
  EXPECT_FALSE(source->read(frame));
}

TEST(ListFile, RelativePathsCommentsAndBlankLines) {
  auto dir = scratchDir("ListFile_parse");
  fs::create_directories(dir / "images");
  writeBytes(dir / "frames.txt",
             "# a comment\n\nimages/0.png\n   images/1.png  \r\n#images/skip.png\n/abs/2.png\n"
             "images/3.png");
  auto paths = readListFile(dir / "frames.txt");
  ASSERT_EQ(paths.size(), 4u);
  EXPECT_EQ(paths[0], (dir / "images/0.png").string());
  EXPECT_EQ(paths[1], (dir / "images/1.png").string());
  EXPECT_EQ(paths[2], "/abs/2.png");
  EXPECT_EQ(paths[3], (dir / "images/3.png").string());
}

TEST(ListFile, BinaryFileIsRefusedAsSource) {
  auto dir = scratchDir("ListFile_binary");
  writeBytes(dir / "garbage.bin", std::string("\x01\x00\x02junk", 7));
  try {
    ImageSource::open((dir / "garbage.bin").string());
    FAIL() << "a binary file was accepted as a list file";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kIo);
  }
}

TEST(ImageSourceOpen, MissingSourceIsAnIoError) {
  try {
    ImageSource::open("/nonexistent/placedb/source");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kIo);
    EXPECT_NE(std::string(e.what()).find("/nonexistent/placedb/source"), std::string::npos);
  }
}

TEST(ReadImage, UnreadableImagesAreReportedNotThrown) {
  auto dir = scratchDir("ReadImage_unreadable");
  std::vector<unsigned char> jpeg;
  cv::imencode(".jpg", pattern(), jpeg);
  std::string good(jpeg.begin(), jpeg.end());
  writeBytes(dir / "good.jpg", good);
  writeBytes(dir / "empty.jpg", "");
  writeBytes(dir / "truncated.jpg", good.substr(0, good.size() / 2));
  std::mt19937 random(7);
  std::string noise(4096, '\0');
  for (char& c : noise) c = static_cast<char>(random() & 0xFF);
  writeBytes(dir / "random.png", noise);

  std::string problem;
  EXPECT_FALSE(readImageFile((dir / "good.jpg").string(), problem).empty()) << problem;
  for (const char* bad : {"empty.jpg", "truncated.jpg", "random.png", "missing.jpg"}) {
    problem.clear();
    EXPECT_TRUE(readImageFile((dir / bad).string(), problem).empty()) << bad;
    EXPECT_FALSE(problem.empty()) << bad;
  }
}

}  // namespace
}  // namespace placedb::cli
