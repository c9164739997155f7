#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "synthetic/ripmap.h"

namespace placedb::synthetic {
namespace {

TEST(RipMap, FootprintsFilterWhatASinglePixelCovers) {
  // Stripes one texel wide across the columns: a pixel that spans many columns sees their
  // mean, one that spans many rows (along the stripes) still sees them sharp.
  cv::Mat stripes(64, 256, CV_8U);
  for (int col = 0; col < stripes.cols; ++col) stripes.col(col).setTo(col % 2 ? 200 : 40);
  const RipMap map(stripes);
  EXPECT_FLOAT_EQ(map.sample(map.blend(1, 1), 10, 5), 40);
  EXPECT_FLOAT_EQ(map.sample(map.blend(1, 1), 11, 5), 200);
  EXPECT_NEAR(map.sample(map.blend(16, 1), 10, 5), 120, 1);
  EXPECT_NEAR(map.sample(map.blend(5.3f, 1), 77.4f, 5), 120, 1);
  EXPECT_FLOAT_EQ(map.sample(map.blend(1, 16), 11, 5), 200);
  // Beyond the edges, the edge texels.
  EXPECT_FLOAT_EQ(map.sample(map.blend(1, 1), -30, -30), 40);
}

}  // namespace
}  // namespace placedb::synthetic
