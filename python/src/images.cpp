#include "images.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "features/image_conversion.h"
#include "placedb/error.h"
#include "sources/image_source.h"

namespace py = pybind11;

namespace placedb::python {
namespace {

[[noreturn]] void refuse(const std::string& why) {
  throw Error(ErrorCode::kInvalidArgument, "image: " + why);
}

int depthOf(const py::dtype& type) {
  if (type.equal(py::dtype::of<std::uint8_t>())) return CV_8U;
  if (type.equal(py::dtype::of<std::uint16_t>())) return CV_16U;
  if (type.equal(py::dtype::of<float>())) return CV_32F;
  if (type.equal(py::dtype::of<double>())) return CV_64F;
  refuse("dtype " + py::str(py::handle(type)).cast<std::string>() +
         " is not supported (uint8, uint16, float32, float64)");
}

}  // namespace

cv::Mat imageOf(const py::array& image, py::array& contiguous) {
  if (image.ndim() != 2 && image.ndim() != 3)
    refuse(std::to_string(image.ndim()) + " dimensions, expected H x W or H x W x C");
  const int channels = image.ndim() == 3 ? static_cast<int>(image.shape(2)) : 1;
  if (channels != 1 && channels != 3 && channels != 4)
    refuse(std::to_string(channels) + " channels, expected 1, 3 (BGR) or 4 (BGRA)");
  if (image.shape(0) == 0 || image.shape(1) == 0) refuse("empty");
  // Judged from the shape, before the copy below: a stride-0 view of 100000 x 100000 pixels is a
  // few bytes of numpy and ~10 GB once made contiguous.
  const auto side = [](py::ssize_t n) {
    return static_cast<std::uint32_t>(std::min<py::ssize_t>(n, 0xffffffff));
  };
  const ImageDimensions size{side(image.shape(1)), side(image.shape(0))};
  if (!withinImageLimits(size)) refuse(imageLimitProblem(size));
  const int depth = depthOf(image.dtype());
  // Slices and transposes are copied into one C-ordered block; a C-ordered array is used as is.
  contiguous = py::array::ensure(image, py::array::c_style);
  if (!contiguous) throw py::error_already_set();
  return cv::Mat(static_cast<int>(image.shape(0)), static_cast<int>(image.shape(1)),
                 CV_MAKETYPE(depth, channels), const_cast<void*>(contiguous.data()));
}

cv::Mat readImage(const std::string& path) {
  std::string problem;
  cv::Mat image;
  {
    py::gil_scoped_release unlocked;
    image = cli::readImageFile(path, problem);
  }
  if (image.empty()) throw Error(ErrorCode::kIo, "cannot read image " + path + ": " + problem);
  return image;
}

py::array arrayOf(const cv::Mat& image) {
  if (image.depth() != CV_8U) throw Error(ErrorCode::kInternal, "image: not 8-bit");
  std::vector<py::ssize_t> shape{image.rows, image.cols};
  if (image.channels() > 1) shape.push_back(image.channels());
  py::array_t<std::uint8_t> out(shape);
  const std::size_t row_bytes = static_cast<std::size_t>(image.cols) * image.elemSize();
  for (int r = 0; r < image.rows; ++r)
    std::memcpy(out.mutable_data() + static_cast<std::size_t>(r) * row_bytes, image.ptr(r),
                row_bytes);
  return out;
}

}  // namespace placedb::python
