// makeFeatureExtractor: which names it builds, what it refuses for mapping, and option checks.
#include <gtest/gtest.h>

#include <limits>
#include <string>

#include "features/feature_extractor.h"
#include "placedb/error.h"

namespace placedb {
namespace {

ErrorCode factoryError(const FeatureOptions& options, bool for_mapping) {
  try {
    makeFeatureExtractor(options, for_mapping);
  } catch (const Error& e) {
    return e.code();
  }
  ADD_FAILURE() << "extractor '" << options.extractor << "' was built";
  return ErrorCode::kInternal;
}

TEST(ExtractorFactory, BuildsEveryFloatExtractorWithItsSignature) {
  const std::pair<const char*, const char*> expected[] = {
      {"surf", "surf-64"}, {"sift", "sift-128"}, {"kaze", "kaze-64"}};
  for (const auto& [name, signature] : expected) {
    FeatureOptions options;
    options.extractor = name;
    const auto extractor = makeFeatureExtractor(options);
    EXPECT_EQ(extractor->name(), name);
    EXPECT_EQ(extractor->signature(), signature);
    EXPECT_EQ(extractor->type(), DescriptorType::kFloat32);
  }
}

TEST(ExtractorFactory, DefaultIsSurf64) {
  EXPECT_EQ(makeFeatureExtractor(FeatureOptions())->signature(), "surf-64");
}

TEST(ExtractorFactory, OrbIsRefusedForMappingButAvailableOtherwise) {
  FeatureOptions options;
  options.extractor = "orb";
  EXPECT_EQ(factoryError(options, /*for_mapping=*/true), ErrorCode::kInvalidArgument);
  const auto orb = makeFeatureExtractor(options, /*for_mapping=*/false);
  EXPECT_EQ(orb->type(), DescriptorType::kBinary8U);
  EXPECT_EQ(orb->signature(), "orb-32");
}

TEST(ExtractorFactory, UnknownNameAndOutOfRangeOptionsAreRefused) {
  FeatureOptions unknown;
  unknown.extractor = "brisk";
  EXPECT_EQ(factoryError(unknown, false), ErrorCode::kInvalidArgument);

  FeatureOptions negative_threshold;
  negative_threshold.hessian_threshold = -1;
  EXPECT_EQ(factoryError(negative_threshold, true), ErrorCode::kInvalidArgument);

  FeatureOptions nan_threshold;
  nan_threshold.hessian_threshold = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(factoryError(nan_threshold, true), ErrorCode::kInvalidArgument);

  FeatureOptions no_octaves;
  no_octaves.octaves = 0;
  EXPECT_EQ(factoryError(no_octaves, true), ErrorCode::kInvalidArgument);

  FeatureOptions negative_cap;
  negative_cap.max_features = -5;
  EXPECT_EQ(factoryError(negative_cap, true), ErrorCode::kInvalidArgument);
}

TEST(ExtractorFactory, ExtractRefusesImagesItCannotUse) {
  const auto surf = makeFeatureExtractor(FeatureOptions());
  for (const cv::Mat& bad :
       {cv::Mat(), cv::Mat(20, 200, CV_8UC1, cv::Scalar(1)),
        cv::Mat(100, 100, CV_8UC3, cv::Scalar(1)), cv::Mat(100, 100, CV_16UC1, cv::Scalar(1))}) {
    try {
      surf->extract(bad);
      ADD_FAILURE() << "accepted a " << bad.cols << "x" << bad.rows << " image of type "
                    << bad.type();
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument) << e.what();
    }
  }
}

}  // namespace
}  // namespace placedb
