#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include <opencv2/imgproc.hpp>

#include "synthetic/ground_truth.h"
#include "synthetic/seeded_random.h"
#include "synthetic/synthetic_sequence.h"

namespace placedb::synthetic {
namespace {

SyntheticOptions demoOptions(int frames, std::uint64_t seed) {
  SyntheticOptions options;
  options.frames = frames;
  options.seed = seed;
  return options;
}

// Normalised cross-correlation of two images over a mask.
double maskedNcc(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask) {
  cv::Scalar mean_a, std_a, mean_b, std_b;
  cv::meanStdDev(a, mean_a, std_a, mask);
  cv::meanStdDev(b, mean_b, std_b, mask);
  cv::Mat fa, fb;
  a.convertTo(fa, CV_64F, 1, -mean_a[0]);
  b.convertTo(fb, CV_64F, 1, -mean_b[0]);
  const double covariance = cv::mean(fa.mul(fb), mask)[0];
  return covariance / (std_a[0] * std_b[0] + 1e-9);
}

TEST(GroundTruth, SpatialHashFindsExactlyWhatBruteForceFinds) {
  const SyntheticSequence sequence(demoOptions(700, 3));
  std::vector<Pose> poses;
  for (int i = 0; i < sequence.size(); ++i) poses.push_back(sequence.pose(i));
  const GroundTruthSettings settings;  // the same definition as the sequence's defaults
  std::vector<std::pair<int, int>> brute;
  for (int q = 0; q < sequence.size(); ++q) {
    for (int r = 0; q - r >= settings.min_gap; ++r) {
      const double turn = std::abs(std::remainder(poses[q].heading - poses[r].heading, 2 * CV_PI));
      if (turn > settings.max_heading) continue;
      if (footprintOverlap(sequence.footprint(q), sequence.footprint(r)) >= settings.min_overlap) {
        brute.emplace_back(q, r);
      }
    }
  }
  ASSERT_FALSE(brute.empty());
  EXPECT_EQ(computeRevisits(poses, sequence.camera(), settings), brute);
  EXPECT_EQ(sequence.groundTruth(), brute);
}

// For ground-truth pairs the known homography lines the two images up: after warping r onto q
// they share most of the picture and it correlates strongly, through exposure and noise changes.
TEST(GroundTruth, PairsShareTheirContent) {
  const SyntheticSequence sequence(demoOptions(800, 11));
  const auto& pairs = sequence.groundTruth();
  ASSERT_GT(pairs.size(), 50u);
  const cv::Size size(sequence.camera().width, sequence.camera().height);
  const cv::Mat full(size, CV_8U, cv::Scalar(255));
  SeededRandom pick(1);
  for (int k = 0; k < 12; ++k) {
    const auto [q, r] = pairs[pick.intIn(0, static_cast<int>(pairs.size()) - 1)];
    ASSERT_GE(q - r, sequence.options().min_revisit_gap);
    const cv::Matx33d r_to_q = sequence.homography(r, q);
    cv::Mat warped, mask;
    cv::warpPerspective(sequence.render(r), warped, r_to_q, size);
    cv::warpPerspective(full, mask, r_to_q, size, cv::INTER_NEAREST);
    cv::erode(mask, mask, cv::Mat(), cv::Point(-1, -1), 2);
    const double shared = cv::countNonZero(mask) / static_cast<double>(mask.total());
    EXPECT_GT(shared, 0.4) << "pair " << q << " " << r;
    EXPECT_GT(maskedNcc(sequence.render(q), warped, mask), 0.75) << "pair " << q << " " << r;
  }
}

// Frames far apart in space see disjoint ground and unrelated pictures.
TEST(GroundTruth, DistantFramesShareNothing) {
  const SyntheticSequence sequence(demoOptions(800, 11));
  SeededRandom pick(2);
  int checked = 0;
  double ncc_sum = 0;
  while (checked < 20) {
    const int a = pick.intIn(0, sequence.size() - 1), b = pick.intIn(0, sequence.size() - 1);
    const Pose pa = sequence.pose(a), pb = sequence.pose(b);
    if (std::hypot(pa.x - pb.x, pa.y - pb.y) < 40) continue;
    EXPECT_EQ(footprintOverlap(sequence.footprint(a), sequence.footprint(b)), 0);
    const auto refs = sequence.revisitsOf(std::max(a, b));
    EXPECT_EQ(std::count(refs.begin(), refs.end(), std::min(a, b)), 0);
    const cv::Mat mask(sequence.render(a).size(), CV_8U, cv::Scalar(255));
    const double ncc = maskedNcc(sequence.render(a), sequence.render(b), mask);
    EXPECT_LT(std::abs(ncc), 0.45);
    ncc_sum += std::abs(ncc);
    ++checked;
  }
  EXPECT_LT(ncc_sum / checked, 0.2);
}

TEST(GroundTruth, RevisitsOfAgreesWithThePairList) {
  const SyntheticSequence sequence(demoOptions(600, 5));
  std::size_t total = 0;
  for (int q = 0; q < sequence.size(); ++q) {
    const auto refs = sequence.revisitsOf(q);
    total += refs.size();
    for (std::size_t k = 0; k < refs.size(); ++k) {
      EXPECT_GE(q - refs[k], sequence.options().min_revisit_gap);
      if (k > 0) {
        EXPECT_LT(refs[k - 1], refs[k]);
      }
    }
  }
  EXPECT_EQ(total, sequence.groundTruth().size());
}

}  // namespace
}  // namespace placedb::synthetic
