// --calibration FILE: a line `fx fy cx cy` or an OpenCV file with camera_matrix; every refusal
// names the file.
#include "calibration_file.h"

#include <gtest/gtest.h>

#include <fstream>

#include "placedb/error.h"
#include "settings_input.h"
#include "test_paths.h"

namespace placedb::cli {
namespace {

void expectRefused(const std::string& content, const std::string& reason) {
  try {
    parseCalibration(content, "cam.txt");
    ADD_FAILURE() << "accepted: " << content;
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    const std::string what = e.what();
    EXPECT_NE(what.find("cam.txt"), std::string::npos) << what;
    EXPECT_NE(what.find(reason), std::string::npos) << what;
  }
}

TEST(CalibrationFile, OneLineOfFourNumbers) {
  const auto s = parseCalibration("# lip6, assumed\n\n190 190.5 120 96  # pixels\n", "cam.txt");
  EXPECT_EQ(s, (std::map<std::string, std::string>{
                   {"fx", "190"}, {"fy", "190.5"}, {"cx", "120"}, {"cy", "96"}}));
  expectRefused("190 190 120\n", "is not four numbers");
  expectRefused("190 190 120 96 1\n", "is not four numbers");
  expectRefused("190 190 120 96\n190 190 120 96\n", "more than one line");
  expectRefused("# nothing\n", "no values");
  expectRefused("190 -190 120 96\n", "fy = -190 is not a positive number");
}

TEST(CalibrationFile, OpenCvYamlCameraMatrix) {
  const std::string yaml =
      "%YAML:1.0\n---\nimage_width: 512\ncamera_matrix: !!opencv-matrix\n   rows: 3\n"
      "   cols: 3\n   dt: d\n   data: [ 420.5, 0., 256., 0., 421., 192.25, 0., 0., 1. ]\n";
  const auto s = parseCalibration(yaml, "cam.yml");
  EXPECT_EQ(s.at("fx"), "420.5");
  EXPECT_EQ(s.at("fy"), "421");
  EXPECT_EQ(s.at("cx"), "256");
  EXPECT_EQ(s.at("cy"), "192.25");
  expectRefused("%YAML:1.0\n---\nimage_width: 512\n", "no 3x3 camera_matrix");
}

// As ROS's camera_calibration writes it (ost.yaml): plain YAML, matrices as {rows, cols, data}.
const char* kRosCalibration =
    "image_width: 512\n"
    "image_height: 384\n"
    "camera_name: narrow_stereo\n"
    "camera_matrix:\n"
    "  rows: 3\n"
    "  cols: 3\n"
    "  data: [420.5, 0, 256, 0, 421, 192.25, 0, 0, 1]\n"
    "distortion_model: plumb_bob\n"
    "distortion_coefficients:\n"
    "  rows: 1\n"
    "  cols: 5\n"
    "  data: [-0.1, 0.01, 0, 0, 0]\n"
    "rectification_matrix:\n"
    "  rows: 3\n"
    "  cols: 3\n"
    "  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n"
    "projection_matrix:\n"
    "  rows: 3\n"
    "  cols: 4\n"
    "  data: [410, 0, 256, 0, 0, 411, 192, 0, 0, 0, 1, 0]\n";

TEST(CalibrationFile, RosCameraCalibrationYaml) {
  const auto s = parseCalibration(kRosCalibration, "ost.yaml");
  EXPECT_EQ(s.at("fx"), "420.5");
  EXPECT_EQ(s.at("fy"), "421");
  EXPECT_EQ(s.at("cx"), "256");
  EXPECT_EQ(s.at("cy"), "192.25");
  expectRefused("camera_matrix:\n  rows: 3\n  cols: 3\n  data: [420.5, 0, 256, 0, 421]\n",
                "no 3x3 camera_matrix");
  expectRefused("camera_matrix:\n  rows: 2\n  cols: 2\n  data: [1, 0, 0, 1]\n",
                "no 3x3 camera_matrix");
}

TEST(CalibrationFile, FileBetweenConfigAndSet) {
  const auto dir = placedb::testing::scratchDir("CalibrationFile");
  std::ofstream(dir / "cam.txt") << "190 190 120 96\n";
  SettingsInput input;
  input.calibration_file = (dir / "cam.txt").string();
  EXPECT_FALSE(input.empty());
  input.assignments = {"cx=121"};
  const Options o = resolveOptions(input);
  EXPECT_EQ(o.fx, 190);
  EXPECT_EQ(o.cx, 121);  // --set wins
  EXPECT_EQ(o.cy, 96);
  input.calibration_file = (dir / "absent.txt").string();
  try {
    resolveOptions(input);
    ADD_FAILURE() << "a missing calibration file was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kIo);
    EXPECT_NE(std::string(e.what()).find("absent.txt"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace placedb::cli
