#pragma once
// Turning whatever OpenCV reads into the 8-bit grey image every extractor takes.
#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

#include "features/image_header.h"

namespace placedb {

// Images smaller than this on either side are refused: the smallest SURF filter (9 px) plus its
// 20-scale descriptor window would leave nothing to detect.
constexpr int kMinImageSide = 32;

// Images larger than this are refused from their header, before they are decoded: a valid PNG of
// a few hundred kilobytes can claim 20000 x 20000 pixels and decode to 400 MB, and OpenCV's own
// cap (2^30 pixels, OPENCV_IO_MAX_IMAGE_PIXELS) is read once when libopencv_imgcodecs loads, so a
// library cannot lower it. 40 MP leaves room above an 8K UHD frame (7680 x 4320, 33 MP); the side
// limit refuses strips that no camera takes, which the pixel count alone would let through.
constexpr int kMaxImageSide = 16384;
constexpr std::int64_t kMaxImagePixels = 40'000'000;

// Whether an image of `size` is within kMaxImageSide and kMaxImagePixels.
bool withinImageLimits(const ImageDimensions& size);
// "W x H pixels; the limit is ... pixels a side and ... megapixels", for refusal messages.
std::string imageLimitProblem(const ImageDimensions& size);

// Converts any image to CV_8UC1:
//  - channels: 1 as is; 2 (grey + alpha) keeps the grey channel; 3 (BGR) and 4 (BGRA) use
//    OpenCV's luma weights. Alpha is ignored, not composited: transparent pixels keep their
//    colour so that features do not depend on what the writer put behind them.
//  - depth: 8U as is; 16U is divided by 256 (a fixed scale, so frames of one sequence keep the
//    same brightness relation, unlike per-image stretching); 32F/64F are taken as [0, 1] and
//    multiplied by 255 (OpenCV's convention for float images), saturating; signed integer
//    depths (8S/16S/32S), having no such convention, are stretched from the image's own
//    min..max to 0..255.
// Throws Error(kInvalidArgument) when the image is empty or smaller than kMinImageSide.
cv::Mat toGrey8(const cv::Mat& image);

// Reads a file with cv::imread(IMREAD_UNCHANGED) and converts it with toGrey8().
// Throws Error(kIo) naming the file when it is missing or cannot be decoded, and
// Error(kInvalidArgument) naming the file when it is empty or too small, or when its header
// (see image_header.h) claims more than the limits above; that check runs before decoding.
cv::Mat loadGreyImage(const std::string& path);

// Throws Error(kInvalidArgument) unless `grey8` is a CV_8UC1 image of at least kMinImageSide
// pixels each side. `who` starts the message (e.g. the extractor's name).
void requireExtractableImage(const cv::Mat& grey8, const std::string& who);

}  // namespace placedb
