#include "calibration_file.h"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <optional>
#include <sstream>

#include <opencv2/core.hpp>

#include "placedb/error.h"
#include "text_file.h"

namespace placedb::cli {
namespace {

[[noreturn]] void refuse(const std::string& name, const std::string& why) {
  throw Error(ErrorCode::kInvalidArgument,
              fmt::format("calibration file {}: {} (expected one line `fx fy cx cy`, an OpenCV "
                          "YAML/XML/JSON file with a 3x3 camera_matrix, or ROS "
                          "camera_calibration's YAML)",
                          name, why));
}

std::map<std::string, std::string> settingsOf(const std::array<double, 4>& values,
                                              const std::string& name) {
  const char* keys[] = {"fx", "fy", "cx", "cy"};
  std::map<std::string, std::string> out;
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i]) || values[i] <= 0)
      refuse(name, fmt::format("{} = {} is not a positive number", keys[i], values[i]));
    out[keys[i]] = fmt::format("{}", values[i]);
  }
  return out;
}

// ROS's camera_calibration writes a matrix as a plain map {rows, cols, data: [row-major]}.
cv::Mat rosMatrix(const cv::FileNode& node) {
  const cv::FileNode data = node["data"];
  if (!node.isMap() || !data.isSeq() || static_cast<int>(node["rows"]) <= 0 ||
      static_cast<int>(node["cols"]) <= 0)
    return cv::Mat();
  const int rows = static_cast<int>(node["rows"]), cols = static_cast<int>(node["cols"]);
  if (data.size() != static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols))
    return cv::Mat();
  cv::Mat m(rows, cols, CV_64F);
  int i = 0;
  for (const cv::FileNode& value : data) {
    m.at<double>(i / cols, i % cols) = value.real();
    ++i;
  }
  return m;
}

std::map<std::string, std::string> parseOpenCv(const std::string& content,
                                               const std::string& name) {
  cv::Mat k;
  try {
    // OpenCV reads YAML only after its own header line; ROS's files have none.
    const bool yaml_without_header = trim(content).rfind("%YAML", 0) != 0 &&
                                     trim(content).rfind("<?xml", 0) != 0 &&
                                     trim(content).rfind("{", 0) != 0;
    cv::FileStorage fs(yaml_without_header ? "%YAML:1.0\n---\n" + content : content,
                       cv::FileStorage::READ | cv::FileStorage::MEMORY);
    if (!fs.isOpened()) refuse(name, "not a readable OpenCV file");
    const cv::FileNode node = fs["camera_matrix"];
    if (node.isMap() && node["data"].isSeq() && !node["dt"].isString())
      k = rosMatrix(node);
    else
      node >> k;
  } catch (const cv::Exception& e) {
    refuse(name, fmt::format("not a readable OpenCV file ({})", e.msg));
  }
  if (k.rows != 3 || k.cols != 3) refuse(name, "no 3x3 camera_matrix");
  k.convertTo(k, CV_64F);
  return settingsOf(
      {k.at<double>(0, 0), k.at<double>(1, 1), k.at<double>(0, 2), k.at<double>(1, 2)}, name);
}

}  // namespace

std::map<std::string, std::string> parseCalibration(const std::string& text,
                                                    const std::string& name) {
  const std::string content = withoutByteOrderMark(text);
  const std::string head = trim(content);
  if (head.rfind("%YAML", 0) == 0 || head.rfind("<?xml", 0) == 0 || head.rfind("{", 0) == 0 ||
      content.find("camera_matrix") != std::string::npos)
    return parseOpenCv(content, name);
  std::istringstream lines(content);
  std::optional<std::array<double, 4>> found;
  for (std::string line; std::getline(lines, line);) {
    line = trim(line.substr(0, line.find('#')));
    if (line.empty()) continue;
    if (found) refuse(name, "more than one line of values");
    std::istringstream fields(line);
    std::array<double, 4> values{};
    for (double& v : values)
      if (!(fields >> v)) refuse(name, fmt::format("`{}` is not four numbers", line));
    std::string extra;
    if (fields >> extra) refuse(name, fmt::format("`{}` is not four numbers", line));
    found = values;
  }
  if (!found) refuse(name, "no values");
  return settingsOf(*found, name);
}

std::map<std::string, std::string> readCalibrationFile(const std::filesystem::path& path) {
  return parseCalibration(readTextFile(path, "calibration file"), path.string());
}

}  // namespace placedb::cli
