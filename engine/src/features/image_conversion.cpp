#include "features/image_conversion.h"

#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "placedb/error.h"

namespace placedb {
namespace {

std::string sizeText(const cv::Mat& image) {
  return std::to_string(image.cols) + "x" + std::to_string(image.rows);
}

void requireUsableSize(const cv::Mat& image, const std::string& who) {
  if (image.empty()) throw Error(ErrorCode::kInvalidArgument, who + ": image is empty");
  if (image.rows < kMinImageSide || image.cols < kMinImageSide) {
    throw Error(ErrorCode::kInvalidArgument,
                who + ": image is " + sizeText(image) + ", smaller than the minimum of " +
                    std::to_string(kMinImageSide) + " pixels each side");
  }
}

cv::Mat toDepth8U(const cv::Mat& image) {
  cv::Mat out;
  switch (image.depth()) {
    case CV_8U:
      return image;
    case CV_16U:
      image.convertTo(out, CV_8U, 1.0 / 256.0);
      return out;
    case CV_32F:
    case CV_64F:
      image.convertTo(out, CV_8U, 255.0);
      return out;
    default: {
      // Signed integers: stretch the image's own range over all channels.
      double low = 0, high = 0;
      cv::minMaxLoc(image.reshape(1), &low, &high);
      const double scale = high > low ? 255.0 / (high - low) : 0.0;
      image.convertTo(out, CV_8U, scale, -low * scale);
      return out;
    }
  }
}

}  // namespace

bool withinImageLimits(const ImageDimensions& size) {
  return size.width <= static_cast<std::uint32_t>(kMaxImageSide) &&
         size.height <= static_cast<std::uint32_t>(kMaxImageSide) &&
         static_cast<std::int64_t>(size.width) * size.height <= kMaxImagePixels;
}

std::string imageLimitProblem(const ImageDimensions& size) {
  return std::to_string(size.width) + " x " + std::to_string(size.height) +
         " pixels; the limit is " + std::to_string(kMaxImageSide) + " pixels a side and " +
         std::to_string(kMaxImagePixels / 1'000'000) + " megapixels";
}

cv::Mat toGrey8(const cv::Mat& image) {
  requireUsableSize(image, "image conversion");
  const cv::Mat depth8 = toDepth8U(image);
  cv::Mat grey;
  switch (depth8.channels()) {
    case 1:
      grey = depth8;
      break;
    case 2:
      cv::extractChannel(depth8, grey, 0);
      break;
    case 3:
      cv::cvtColor(depth8, grey, cv::COLOR_BGR2GRAY);
      break;
    case 4:
      cv::cvtColor(depth8, grey, cv::COLOR_BGRA2GRAY);
      break;
    default:
      throw Error(ErrorCode::kInvalidArgument,
                  "image conversion: " + std::to_string(depth8.channels()) +
                      " channels are not supported (1 to 4)");
  }
  // Callers may keep the result while the caller's image changes: never alias it.
  return grey.data == image.data ? grey.clone() : grey;
}

cv::Mat loadGreyImage(const std::string& path) {
  std::error_code ignored;
  if (!std::filesystem::is_regular_file(path, ignored)) {
    throw Error(ErrorCode::kIo, "cannot read image '" + path + "': no such file");
  }
  // Before imread: decoding is what allocates the pixels.
  const std::optional<ImageDimensions> size = readImageFileDimensions(path);
  if (size && !withinImageLimits(*size)) {
    throw Error(ErrorCode::kInvalidArgument, "image '" + path + "' is " + imageLimitProblem(*size));
  }
  cv::Mat raw;
  try {
    raw = cv::imread(path, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw Error(ErrorCode::kIo, "cannot decode image '" + path + "': " + e.what());
  }
  if (raw.empty()) {
    throw Error(ErrorCode::kIo,
                "cannot decode image '" + path + "': not an image format OpenCV can read");
  }
  try {
    return toGrey8(raw);
  } catch (const Error& e) {
    throw Error(e.code(), "image '" + path + "': " + e.what());
  }
}

void requireExtractableImage(const cv::Mat& grey8, const std::string& who) {
  requireUsableSize(grey8, who);
  if (grey8.type() != CV_8UC1) {
    throw Error(ErrorCode::kInvalidArgument,
                who + ": needs an 8-bit single-channel image (convert it with toGrey8())");
  }
}

}  // namespace placedb
