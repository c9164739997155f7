#include "synthetic/synthetic_sequence.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "placedb/error.h"
#include "synthetic/canyon.h"
#include "synthetic/ground_texture.h"
#include "synthetic/ground_truth.h"
#include "synthetic/route_planner.h"
#include "synthetic/seeded_random.h"

namespace placedb::synthetic {
namespace {

constexpr double kDegree = CV_PI / 180.0;

// Salts keep the independent random streams of one seed apart.
enum Salt : std::uint64_t {
  kLateralSalt = 11,
  kHeadingSalt,
  kPitchSalt,
  kHeightSalt,
  kGainSalt,
  kBiasSalt,
  kShadeXSalt,
  kShadeYSalt,
  kNoiseSalt,
  kWorldSalt,
};

void require(bool ok, const std::string& what) {
  if (!ok) throw Error(ErrorCode::kInvalidArgument, "synthetic sequence: " + what);
}

SyntheticOptions withProfileDefaults(SyntheticOptions o) {
  require(o.profile == "demo" || o.profile == "scale" || o.profile == "single_pass",
          "profile must be \"demo\", \"scale\" or \"single_pass\", not \"" + o.profile + "\"");
  const bool scale = o.profile == "scale";
  if (o.revisit_fraction < 0) o.revisit_fraction = scale ? 0.25 : 0.4;
  if (o.first_revisit_fraction < 0) o.first_revisit_fraction = scale ? 0.1 : 0.35;
  if (o.block_length <= 0) {
    // Small demos get small blocks so that a loop round a block fits into a few hundred frames.
    o.block_length = scale ? 40.0 : std::clamp(o.frames * o.speed / 18.0, 12.0, 40.0);
  }
  return o;
}

void validate(const SyntheticOptions& o, const CameraIntrinsics& camera) {
  require(o.frames >= 1, "frames must be at least 1");
  require(o.width >= 16 && o.height >= 16 && o.width <= 8192 && o.height <= 8192,
          "image size must be between 16 and 8192 pixels");
  require(o.revisit_fraction >= 0 && o.revisit_fraction <= 0.8,
          "revisit_fraction must be in [0, 0.8]");
  require(o.first_revisit_fraction >= 0 && o.first_revisit_fraction <= 0.9,
          "first_revisit_fraction must be in [0, 0.9]");
  require(o.min_revisit_gap >= 1, "min_revisit_gap must be at least 1");
  require(o.speed > 0 && o.speed < 10, "speed must be in (0, 10) metres per frame");
  require(o.camera_height > 0.5 && o.camera_height < 100, "camera_height must be in (0.5, 100)");
  require(o.hfov_degrees > 10 && o.hfov_degrees < 120, "hfov_degrees must be in (10, 120)");
  require(o.gt_min_shared > 0 && o.gt_min_shared <= 1, "gt_min_shared must be in (0, 1]");
  require(o.noise_sigma >= 0 && o.lateral_wander >= 0 && o.height_wander >= 0 &&
              o.pitch_wander_degrees >= 0,
          "wander and noise must not be negative");
  require(o.lookalike_gap >= 1 && o.lookalike_pitch > 0,
          "lookalike gap and pitch must be positive");
  require(o.ground_contrast >= 0 && o.ground_contrast <= 1, "ground_contrast must be in [0, 1]");
  require(o.scene == "ground" || o.scene == "corridor" || o.scene == "street",
          "scene must be \"ground\", \"corridor\" or \"street\", not \"" + o.scene + "\"");
  if (o.scene != "ground") {
    validateCanyon(o, camera);
    return;
  }
  // The top image row must stay well below the horizon or the ground footprint is unbounded.
  const double top_ray =
      o.pitch_degrees - o.pitch_wander_degrees - camera.verticalFov() / kDegree / 2;
  require(top_ray >= 10 && o.pitch_degrees + o.pitch_wander_degrees <= 90,
          "pitch_degrees too shallow for the field of view: the image would see the horizon");
}

std::vector<Pose> planPoses(const SyntheticOptions& o, int attempt) {
  const bool scale = o.profile == "scale";
  RouteSettings route;
  route.seed = attempt == 0 ? o.seed : hashOf(o.seed, 0xa77e, attempt);
  route.length = o.frames * o.speed;
  route.block = o.block_length;
  route.turn_radius = std::min(7.0, 0.45 * o.block_length);
  route.revisit_fraction = o.revisit_fraction;
  route.first_revisit_fraction = o.first_revisit_fraction;
  // Old enough by a margin, since the exact gap also depends on the corners cut.
  route.min_gap_length = (1.2 * o.min_revisit_gap + 10) * o.speed;
  route.revisit_chunk_edges[0] = scale ? 3 : 1;
  route.revisit_chunk_edges[1] = scale ? 8 : 4;
  route.explore_chunk_edges[0] = scale ? 4 : 1;
  route.explore_chunk_edges[1] = scale ? 12 : 2;
  route.nearest_of = scale ? 3 : 6;
  std::vector<PathSample> path;
  if (o.profile == "single_pass") {
    for (int i = 0; i < o.frames; ++i) path.push_back({i * o.speed, 0.0, 0.0});
  } else {
    const std::vector<cv::Point> walk = planStreetWalk(route);
    path = samplePath(walk, route.block, route.turn_radius, o.speed, o.frames);
  }

  std::vector<Pose> poses(o.frames);
  for (int i = 0; i < o.frames; ++i) {
    const double t = i;
    Pose& p = poses[i];
    const double heading = path[i].heading;
    const double lateral = o.lateral_wander * smoothNoise1d(o.seed, kLateralSalt, t / 45.0);
    p.x = path[i].x - std::sin(heading) * lateral;
    p.y = path[i].y + std::cos(heading) * lateral;
    p.heading = heading +
                o.heading_wander_degrees * kDegree * smoothNoise1d(o.seed, kHeadingSalt, t / 35.0);
    p.pitch =
        (o.pitch_degrees + o.pitch_wander_degrees * smoothNoise1d(o.seed, kPitchSalt, t / 50.0)) *
        kDegree;
    p.height = o.camera_height + o.height_wander * smoothNoise1d(o.seed, kHeightSalt, t / 60.0);
  }
  return poses;
}

// The ground-truth pairs whose views are alike: the two footprints overlap with IoU >= 0.5 and
// the headings are within 30 degrees, i.e. the same street driven again in the same direction,
// which is what the route planner plans as a repeat. Route variants are chosen on these, not on
// the whole ground truth, so that the frames of a seed do not change when the ground truth's
// rule does (every such pair shares at least half of either footprint, so with gt_min_shared up
// to 0.5 it is in the list).
std::vector<std::pair<int, int>> alikePairs(const std::vector<Pose>& poses,
                                            const CameraIntrinsics& camera,
                                            const std::vector<std::pair<int, int>>& pairs) {
  std::vector<std::pair<int, int>> alike;
  for (const auto& [q, r] : pairs) {
    const ViewRelation v = relateViews(q, poses[q], r, poses[r], camera);
    if (v.iou >= 0.5 && v.heading <= 30.0 * kDegree) alike.emplace_back(q, r);
  }
  return alike;
}

// How far a route's planned repeats (alikePairs()) are from what the options ask for (0 is
// perfect).
double routeScore(const SyntheticOptions& o, const std::vector<std::pair<int, int>>& pairs) {
  int revisiting = 0;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    if (k == 0 || pairs[k].first != pairs[k - 1].first) ++revisiting;
  }
  const double n = o.frames;
  double score = std::abs(revisiting / n - o.revisit_fraction);
  if (!pairs.empty()) {
    const double first = pairs.front().first / n;
    // Early is as wrong as late; a little late is expected (the drive back to an old street).
    score += 0.5 * std::max(0.0, o.first_revisit_fraction - 0.03 - first) +
             0.25 * std::max(0.0, first - o.first_revisit_fraction - 0.1);
  }
  return score;
}

}  // namespace

SyntheticOptions sceneDefaults(const std::string& scene) {
  SyntheticOptions o;
  o.scene = scene;
  if (scene == "ground") return o;
  require(scene == "corridor" || scene == "street",
          "scene must be \"ground\", \"corridor\" or \"street\", not \"" + scene + "\"");
  o.profile = "single_pass";
  o.speed = 0.3;  // a walk
  o.camera_height = 1.5;
  o.pitch_degrees = 6;
  o.hfov_degrees = 60;
  // A walker's sway: a little across the way and up and down, the heading and pitch as before.
  o.lateral_wander = scene == "street" ? 0.4 : 0.2;
  o.height_wander = 0.05;
  // A door and its lockers (2.8 m of wall) every 6 m, as along a corridor of offices: 3 m of wall
  // between them shows the place. At 3 m they cover the walls, and at 960x540 every frame of the
  // walk is then most like its first: the engine never leaves its first location, so a negative
  // check there could never fail.
  o.lookalike_pitch = 6;
  if (scene == "street") {
    o.canyon_half_width = 6;
    o.canyon_height = 10;
    o.canyon_walk_offset = -3.5;  // on the pavement, 2.5 m from the right-hand facades
  }
  return o;
}

SyntheticSequence::SyntheticSequence(const SyntheticOptions& options)
    : options_(withProfileDefaults(options)) {
  const SyntheticOptions& o = options_;
  camera_ = CameraIntrinsics::fromHorizontalFov(o.width, o.height, o.hfov_degrees * kDegree);
  validate(o, camera_);
  if (o.scene == "ground") {
    // Short routes have few streets, so the share of repeated frames comes out coarse; try a
    // few route variants (still a pure function of the seed) and keep the one closest to the
    // plan.
    const int attempts = o.frames <= 5000 && o.profile != "single_pass" ? 6 : 1;
    double best_score = 1e300;
    for (int attempt = 0; attempt < attempts; ++attempt) {
      std::vector<Pose> poses = planPoses(o, attempt);
      GroundTruthSettings gt;
      gt.min_gap = o.min_revisit_gap;
      gt.min_shared = o.gt_min_shared;
      std::vector<std::pair<int, int>> pairs = computeRevisits(poses, camera_, gt);
      const double score = attempts > 1 ? routeScore(o, alikePairs(poses, camera_, pairs)) : 0;
      if (score < best_score) {
        best_score = score;
        poses_ = std::move(poses);
        pairs_ = std::move(pairs);
      }
      if (score < 0.04) break;
    }
    texture_ = std::make_unique<GroundTexture>(hashOf(o.seed, kWorldSalt), o.tile_cache);
    decals_ = placeLookalikes(o, poses_);
  } else {
    // A straight walk in a box never comes back: there is no ground truth to compute (and no
    // ground footprint to compute it from, since a camera that sees the horizon has none).
    poses_ = planPoses(o, 0);
    canyon_ = std::make_unique<CanyonWorld>(o, placeWallLookalikes(o, poses_, canyonBox(o)));
  }
  first_pair_.assign(o.frames + 1, 0);
  for (const auto& pair : pairs_) ++first_pair_[pair.first + 1];
  for (int q = 0; q < o.frames; ++q) first_pair_[q + 1] += first_pair_[q];

  ramp_x_.create(o.height, o.width, CV_32F);
  ramp_y_.create(o.height, o.width, CV_32F);
  for (int v = 0; v < o.height; ++v) {
    for (int u = 0; u < o.width; ++u) {
      ramp_x_.at<float>(v, u) = static_cast<float>((u + 0.5) / o.width - 0.5);
      ramp_y_.at<float>(v, u) = static_cast<float>((v + 0.5) / o.height - 0.5);
    }
  }
}

SyntheticSequence::~SyntheticSequence() = default;

const Pose& SyntheticSequence::checkedPose(int i) const {
  if (i < 0 || i >= size()) {
    throw Error(ErrorCode::kInvalidArgument,
                "synthetic sequence: frame " + std::to_string(i) + " out of range");
  }
  return poses_[i];
}

Pose SyntheticSequence::pose(int i) const { return checkedPose(i); }

void SyntheticSequence::requireGround(const char* what) const {
  if (canyon_) {
    throw Error(ErrorCode::kInvalidArgument, std::string("synthetic sequence: ") + what +
                                                 " exists only in the ground scene, not in \"" +
                                                 options_.scene + "\"");
  }
}

std::array<cv::Point2d, 4> SyntheticSequence::footprint(int i) const {
  requireGround("a footprint");
  return groundFootprint(checkedPose(i), camera_);
}

cv::Matx33d SyntheticSequence::homography(int from, int to) const {
  requireGround("a homography between frames");
  return relativeHomography(checkedPose(from), checkedPose(to), camera_);
}

cv::Mat SyntheticSequence::renderClean(int i) const {
  const Pose& pose = checkedPose(i);
  if (canyon_) return canyon_->render(pose, camera_);
  const double scale = GroundTexture::kTexelsPerMetre;
  double min_col = 1e300, max_col = -1e300, min_row = 1e300, max_row = -1e300;
  for (const cv::Point2d& g : groundFootprint(pose, camera_)) {
    min_col = std::min(min_col, g.x * scale);
    max_col = std::max(max_col, g.x * scale);
    min_row = std::min(min_row, -g.y * scale);
    max_row = std::max(max_row, -g.y * scale);
  }
  const int col0 = static_cast<int>(std::floor(min_col)) - 2;
  const int row0 = static_cast<int>(std::floor(min_row)) - 2;
  const cv::Rect texels(col0, row0, static_cast<int>(std::ceil(max_col)) + 3 - col0,
                        static_cast<int>(std::ceil(max_row)) + 3 - row0);
  const cv::Mat ground = texture_->mosaic(texels);
  const cv::Matx33d ground_to_mosaic(scale, 0, -texels.x,   //
                                     0, -scale, -texels.y,  //
                                     0, 0, 1);
  cv::Mat frame;
  cv::warpPerspective(ground, frame, ground_to_mosaic * imageToGround(pose, camera_),
                      cv::Size(camera_.width, camera_.height),
                      cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REPLICATE);
  if (options_.ground_contrast != 1.0)
    frame.convertTo(frame, CV_8U, options_.ground_contrast, 128 * (1 - options_.ground_contrast));
  paintDecals(frame, decals_, pose, camera_);
  return frame;
}

cv::Mat SyntheticSequence::render(int i) const {
  const SyntheticOptions& o = options_;
  const double t = i;
  const double gain = 1.0 + o.exposure_change * smoothNoise1d(o.seed, kGainSalt, t / 90.0);
  const double bias = o.brightness_change * smoothNoise1d(o.seed, kBiasSalt, t / 110.0);
  const double shade_x = o.shading_change * smoothNoise1d(o.seed, kShadeXSalt, t / 70.0);
  const double shade_y = o.shading_change * smoothNoise1d(o.seed, kShadeYSalt, t / 80.0);
  cv::Mat light;
  renderClean(i).convertTo(light, CV_32F, gain, bias);
  cv::scaleAdd(ramp_x_, shade_x, light, light);
  cv::scaleAdd(ramp_y_, shade_y, light, light);
  if (o.noise_sigma > 0) {
    cv::Mat noise(light.size(), CV_32F);
    cv::RNG rng(hashOf(o.seed, kNoiseSalt, i));
    rng.fill(noise, cv::RNG::NORMAL, 0.0, o.noise_sigma);
    light += noise;
  }
  cv::Mat frame;
  light.convertTo(frame, CV_8U);
  return frame;
}

std::vector<int> SyntheticSequence::revisitsOf(int q) const {
  checkedPose(q);
  std::vector<int> refs;
  for (std::size_t k = first_pair_[q]; k < first_pair_[q + 1]; ++k)
    refs.push_back(pairs_[k].second);
  return refs;
}

std::vector<int> SyntheticSequence::nearestViewsOf(int q) const {
  const std::vector<int> rs = revisitsOf(q);
  std::vector<int> out;
  std::size_t i = 0;
  while (i < rs.size()) {
    std::size_t j = i;
    while (j + 1 < rs.size() && rs[j + 1] <= rs[j] + 2) ++j;
    int best = rs[i];
    double best_iou = -1;
    for (std::size_t k = i; k <= j; ++k) {
      const double iou = relateViews(q, pose(q), rs[k], pose(rs[k]), camera_).iou;
      if (iou > best_iou) {
        best_iou = iou;
        best = rs[k];
      }
    }
    out.push_back(best);
    i = j + 1;
  }
  return out;
}

int SyntheticSequence::revisitingFrames() const {
  int count = 0;
  for (int q = 0; q < size(); ++q) count += first_pair_[q + 1] > first_pair_[q] ? 1 : 0;
  return count;
}

int SyntheticSequence::firstRevisit() const { return pairs_.empty() ? -1 : pairs_.front().first; }

}  // namespace placedb::synthetic
