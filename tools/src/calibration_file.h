#pragma once
// Camera intrinsics from a calibration file (`placedb map --calibration FILE`), as the settings
// fx fy cx cy. Three forms:
//   - text: one line `fx fy cx cy` (pixels; blank lines and '#' comments ignored);
//   - OpenCV FileStorage (YAML, XML or JSON, as cv::calibrateCamera's samples write it) with a
//     3 x 3 `camera_matrix` [fx 0 cx; 0 fy cy; 0 0 1];
//   - ROS camera_calibration's YAML (ost.yaml: image_width, camera_matrix as {rows, cols, data}).
// Distortion coefficients are not used.
// Either is taken to hold the intrinsics of the images as mapped (same size).
#include <filesystem>
#include <map>
#include <string>

namespace placedb::cli {

// Throws placedb::Error(kIo) naming the file when unreadable, kInvalidArgument naming it when
// it holds neither form or values that are not positive finite numbers.
std::map<std::string, std::string> readCalibrationFile(const std::filesystem::path& path);

// The same for a file's content; `name` is named in every error.
std::map<std::string, std::string> parseCalibration(const std::string& content,
                                                    const std::string& name);

}  // namespace placedb::cli
