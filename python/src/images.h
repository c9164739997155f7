#pragma once
// numpy images in, cv::Mat out: grey (H x W) or colour (H x W x C, C = 1, 3 or 4, BGR order as
// OpenCV reads them) of uint8, uint16, float32 or float64.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <opencv2/core.hpp>

#include <string>

namespace placedb::python {

// The returned header points into `contiguous`, which the caller keeps alive while it uses the
// image. Throws placedb::Error(kInvalidArgument) naming what is wrong with the array.
cv::Mat imageOf(const pybind11::array& image, pybind11::array& contiguous);

// An image file read and decoded as `placedb map` reads it (8-bit BGR). Throws
// placedb::Error(kIo) naming the file and why it cannot be read.
cv::Mat readImage(const std::string& path);

// A copy of an 8-bit image as a numpy array: H x W (grey) or H x W x C.
pybind11::array arrayOf(const cv::Mat& image);

}  // namespace placedb::python
