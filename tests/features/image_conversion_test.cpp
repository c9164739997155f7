// toGrey8 / loadGreyImage: every input kind the sequences may hold ends as CV_8UC1, and bad input
// fails with the documented error code.
#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <random>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "error_code.h"
#include "features/image_conversion.h"
#include "placedb/error.h"
#include "test_paths.h"

namespace placedb {
namespace {

using placedb::testing::codeOf;

// A 64x48 ramp so that conversions can be checked pixel by pixel.
cv::Mat greyRamp() {
  cv::Mat grey(48, 64, CV_8UC1);
  for (int y = 0; y < grey.rows; ++y)
    for (int x = 0; x < grey.cols; ++x)
      grey.at<uchar>(y, x) = static_cast<uchar>((x * 4 + y) % 256);
  return grey;
}

TEST(ImageConversion, GreyPassesUnchanged) {
  const cv::Mat grey = greyRamp();
  const cv::Mat out = toGrey8(grey);
  ASSERT_EQ(out.type(), CV_8UC1);
  EXPECT_EQ(cv::norm(out, grey, cv::NORM_INF), 0);
}

TEST(ImageConversion, ColourUsesLumaWeights) {
  cv::Mat bgr(40, 40, CV_8UC3, cv::Scalar(255, 0, 0));       // pure blue
  bgr(cv::Rect(0, 0, 20, 40)).setTo(cv::Scalar(0, 0, 255));  // left half pure red
  const cv::Mat out = toGrey8(bgr);
  ASSERT_EQ(out.type(), CV_8UC1);
  ASSERT_EQ(out.size(), bgr.size());
  // Luma: red weighs 0.299, blue 0.114; a plain channel average would give 85 for both.
  EXPECT_NEAR(out.at<uchar>(10, 5), 76, 1);
  EXPECT_NEAR(out.at<uchar>(10, 35), 29, 1);
}

TEST(ImageConversion, AlphaIsIgnoredNotComposited) {
  cv::Mat bgr(40, 40, CV_8UC3, cv::Scalar(10, 120, 200));
  cv::Mat bgra;
  cv::cvtColor(bgr, bgra, cv::COLOR_BGR2BGRA);
  cv::Mat alpha_plane(40, 40, CV_8UC1, cv::Scalar(0));  // fully transparent
  cv::insertChannel(alpha_plane, bgra, 3);
  EXPECT_EQ(cv::norm(toGrey8(bgra), toGrey8(bgr), cv::NORM_INF), 0);

  // Grey + alpha keeps the grey channel.
  const cv::Mat grey = greyRamp();
  cv::Mat grey_alpha;
  cv::merge(std::vector<cv::Mat>{grey, cv::Mat(grey.size(), CV_8UC1, cv::Scalar(0))}, grey_alpha);
  EXPECT_EQ(cv::norm(toGrey8(grey_alpha), grey, cv::NORM_INF), 0);
}

TEST(ImageConversion, SixteenBitIsDividedBy256) {
  cv::Mat deep(40, 40, CV_16UC1, cv::Scalar(0));
  deep.at<ushort>(0, 0) = 65535;
  deep.at<ushort>(0, 1) = 256 * 100;
  deep.at<ushort>(0, 2) = 255;  // below one step: a fixed scale, not stretching
  const cv::Mat out = toGrey8(deep);
  ASSERT_EQ(out.type(), CV_8UC1);
  EXPECT_EQ(out.at<uchar>(0, 0), 255);
  EXPECT_EQ(out.at<uchar>(0, 1), 100);
  EXPECT_LE(out.at<uchar>(0, 2), 1);
}

TEST(ImageConversion, SixteenBitPngRoundTrip) {
  const auto dir = testing::scratchDir("SixteenBitPngRoundTrip");
  cv::Mat deep(50, 60, CV_16UC3, cv::Scalar(256 * 200, 256 * 200, 256 * 200));
  const std::string path = (dir / "deep.png").string();
  ASSERT_TRUE(cv::imwrite(path, deep));
  const cv::Mat out = loadGreyImage(path);
  ASSERT_EQ(out.type(), CV_8UC1);
  EXPECT_EQ(out.size(), cv::Size(60, 50));
  EXPECT_NEAR(out.at<uchar>(25, 30), 200, 1);
}

TEST(ImageConversion, EmptyAndTinyAreInvalidArguments) {
  EXPECT_EQ(codeOf([] { toGrey8(cv::Mat()); }), ErrorCode::kInvalidArgument);
  EXPECT_EQ(codeOf([] { toGrey8(cv::Mat(kMinImageSide - 1, 100, CV_8UC1, cv::Scalar(5))); }),
            ErrorCode::kInvalidArgument);
  EXPECT_EQ(codeOf([] { toGrey8(cv::Mat(100, kMinImageSide - 1, CV_8UC3, cv::Scalar(5))); }),
            ErrorCode::kInvalidArgument);
  EXPECT_NO_THROW(toGrey8(cv::Mat(kMinImageSide, kMinImageSide, CV_8UC1, cv::Scalar(5))));
}

TEST(ImageConversion, TinyFileIsInvalidArgument) {
  const auto dir = testing::scratchDir("TinyFileIsInvalidArgument");
  const std::string path = (dir / "tiny.png").string();
  ASSERT_TRUE(cv::imwrite(path, cv::Mat(16, 16, CV_8UC1, cv::Scalar(9))));
  EXPECT_EQ(codeOf([&] { loadGreyImage(path); }), ErrorCode::kInvalidArgument);
}

TEST(ImageConversion, MissingFileIsIoErrorNamingIt) {
  const std::string path = (testing::scratchDir("MissingFile") / "absent.png").string();
  try {
    loadGreyImage(path);
    FAIL() << "no error for a missing file";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kIo);
    EXPECT_NE(std::string(e.what()).find("absent.png"), std::string::npos) << e.what();
  }
}

TEST(ImageConversion, RandomBytesFileIsIoError) {
  const auto dir = testing::scratchDir("RandomBytesFile");
  const std::string path = (dir / "noise.jpg").string();
  {
    std::ofstream out(path, std::ios::binary);
    std::mt19937 random(42);
    for (int i = 0; i < 4096; ++i) out.put(static_cast<char>(random() & 0xff));
  }
  EXPECT_EQ(codeOf([&] { loadGreyImage(path); }), ErrorCode::kIo);
}

TEST(ImageConversion, RealFrameLoadsAsGrey) {
  const auto dir = testing::dataset("rtabmap_samples");
  if (dir.empty()) GTEST_SKIP() << "rtabmap_samples not found under " << testing::datasetsDir();
  const cv::Mat colour = cv::imread((dir / "images/1.jpg").string(), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(colour.empty());
  const cv::Mat grey = loadGreyImage((dir / "images/1.jpg").string());
  ASSERT_EQ(grey.type(), CV_8UC1);
  EXPECT_EQ(grey.size(), colour.size());
}

}  // namespace
}  // namespace placedb
