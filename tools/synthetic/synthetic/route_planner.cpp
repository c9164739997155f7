#include "synthetic/route_planner.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <queue>
#include <unordered_map>
#include <unordered_set>

#include "placedb/error.h"
#include "synthetic/seeded_random.h"

namespace placedb::synthetic {
namespace {

const cv::Point kDirections[4] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};  // CCW order

int directionIndex(cv::Point step) {
  for (int d = 0; d < 4; ++d) {
    if (kDirections[d] == step) return d;
  }
  throw Error(ErrorCode::kInternal, "synthetic route: nodes are not grid neighbours");
}

std::uint64_t nodeKey(cv::Point p) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(p.x)) << 32) |
         static_cast<std::uint32_t>(p.y);
}

// Length a rounded corner saves over the two straight half-edges it replaces.
double cornerSaving(double radius) { return (2.0 - CV_PI / 2.0) * radius; }

class WalkPlanner {
 public:
  explicit WalkPlanner(const RouteSettings& settings)
      : settings_(settings),
        rng_(hashOf(settings.seed, 0x70a7e)),
        radius_(std::min(settings.turn_radius, 0.5 * settings.block)) {
    const double explore_edges =
        (1.0 - settings.revisit_fraction) * settings.length / settings.block;
    box_half_ = static_cast<int>(std::ceil(0.5 * std::sqrt(2.5 * explore_edges))) + 1;
    append({0, 0});
    append({1, 0});
  }

  std::vector<cv::Point> plan() {
    const double goal = settings_.length + 2 * settings_.block;
    const double first = settings_.first_revisit_fraction * settings_.length;
    while (length_ < std::min(first, goal)) exploreEdge();
    while (length_ < goal) {
      // Spread the repeats evenly over what follows the first exploration.
      const double share =
          std::clamp((length_ - first) / std::max(1.0, settings_.length - first), 0.0, 1.0);
      const double wanted = settings_.revisit_fraction * settings_.length * share;
      const bool repeat = revisit_length_ < wanted || (revisit_length_ == 0 && length_ >= first);
      if (!(repeat && revisit(rng_.intIn(settings_.revisit_chunk_edges[0],
                                         settings_.revisit_chunk_edges[1])))) {
        const int edges =
            rng_.intIn(settings_.explore_chunk_edges[0], settings_.explore_chunk_edges[1]);
        for (int k = 0; k < edges && length_ < goal; ++k) exploreEdge();
      }
    }
    return walk_;
  }

  // Where the first repeated street begins, metres along the route; negative when none does.
  double firstRepeatLength() const { return first_repeat_length_; }

 private:
  int heading() const { return directionIndex(walk_.back() - walk_[walk_.size() - 2]); }

  bool inBox(cv::Point p) const { return std::abs(p.x) <= box_half_ && std::abs(p.y) <= box_half_; }

  void append(cv::Point node) {
    if (!walk_.empty()) {
      length_ += settings_.block;
      if (walk_.size() >= 2 && directionIndex(node - walk_.back()) != heading()) {
        length_ -= cornerSaving(radius_);
      }
    }
    walk_.push_back(node);
    length_at_.push_back(length_);
    visited_.insert(nodeKey(node));
  }

  void exploreEdge() {
    const int dir = heading();
    const int options[3] = {dir, (dir + 1) % 4, (dir + 3) % 4};
    const double weights[3] = {2.5, 1.0, 1.0};
    double total = 0;
    double usable[3];
    for (int k = 0; k < 3; ++k) {
      const cv::Point next = walk_.back() + kDirections[options[k]];
      const bool fresh = !visited_.count(nodeKey(next)) && inBox(next);
      usable[k] = fresh ? weights[k] : 0;
      total += usable[k];
    }
    if (total > 0) {
      double pick = rng_.uniform(0, total);
      for (int k = 0; k < 3; ++k) {
        pick -= usable[k];
        if (pick < 0 || k == 2) {
          if (usable[k] > 0) {
            append(walk_.back() + kDirections[options[k]]);
            return;
          }
        }
      }
    }
    // Hemmed in by streets already driven: drive to the nearest fresh intersection.
    std::vector<cv::Point> route;
    while (route.empty()) {
      route = drive(
          [this](cv::Point node, int) { return inBox(node) && !visited_.count(nodeKey(node)); });
      if (route.empty()) box_half_ += 2;  // the box is used up: widen the town
    }
    for (cv::Point node : route) append(node);
  }

  // Repeats `edges` old street edges from a stretch driven long enough ago. False when there is
  // no such stretch yet.
  bool revisit(int edges) {
    const double newest_allowed = length_ - settings_.min_gap_length;
    int last_eligible = -1;
    for (int j = 0; j + 1 < static_cast<int>(walk_.size()); ++j) {
      if (length_at_[j + 1] <= newest_allowed) last_eligible = j;
    }
    if (last_eligible < 0) return false;
    int target = -1;
    int best_distance = 0;
    for (int k = 0; k < settings_.nearest_of; ++k) {
      const int j = rng_.intIn(0, last_eligible);
      const cv::Point gap = walk_[j] - walk_.back();
      const int distance = std::abs(gap.x) + std::abs(gap.y);
      if (target < 0 || distance < best_distance) {
        target = j;
        best_distance = distance;
      }
    }
    const cv::Point target_node = walk_[target];
    const int leave_dir = directionIndex(walk_[target + 1] - target_node);
    std::vector<cv::Point> route;
    const bool already_there = walk_.back() == target_node && heading() != (leave_dir + 2) % 4;
    if (!already_there) {
      route = drive([&](cv::Point node, int arrive_dir) {
        return node == target_node && arrive_dir != (leave_dir + 2) % 4;
      });
      if (route.empty()) return false;
    }
    for (cv::Point node : route) append(node);
    if (first_repeat_length_ < 0) first_repeat_length_ = length_;
    const int old_end = last_eligible + 1;
    for (int k = target + 1, done = 0; k <= old_end && done < edges; ++k, ++done) {
      const cv::Point next = walk_[k];
      const double before = length_;
      append(next);
      revisit_length_ += length_ - before;
    }
    return true;
  }

  // Cheapest drive (one per edge, a little more per turn, no U-turns) from the current position
  // to the first intersection satisfying `goal`; excludes the start. Empty when none is found.
  std::vector<cv::Point> drive(const std::function<bool(cv::Point, int)>& goal) const {
    cv::Rect2i bounds(-box_half_ - 2, -box_half_ - 2, 2 * box_half_ + 5, 2 * box_half_ + 5);
    for (cv::Point p : walk_) bounds |= cv::Rect2i(p.x - 2, p.y - 2, 5, 5);
    struct Item {
      double cost;
      int state;
      bool operator>(const Item& other) const { return cost > other.cost; }
    };
    const int width = bounds.width, cells = bounds.width * bounds.height;
    auto stateOf = [&](cv::Point p, int d) {
      return ((p.y - bounds.y) * width + (p.x - bounds.x)) * 4 + d;
    };
    auto nodeOf = [&](int state) {
      const int cell = state / 4;
      return cv::Point(bounds.x + cell % width, bounds.y + cell / width);
    };
    std::vector<double> cost(static_cast<std::size_t>(cells) * 4, 1e18);
    std::vector<int> previous(cost.size(), -1);
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> open;
    const int start = stateOf(walk_.back(), heading());
    cost[start] = 0;
    open.push({0, start});
    while (!open.empty()) {
      const Item item = open.top();
      open.pop();
      if (item.cost > cost[item.state]) continue;
      const cv::Point node = nodeOf(item.state);
      const int arrived = item.state % 4;
      if (item.state != start && goal(node, arrived)) {
        std::vector<cv::Point> route;
        for (int s = item.state; s != start; s = previous[s]) route.push_back(nodeOf(s));
        std::reverse(route.begin(), route.end());
        return route;
      }
      for (int turn : {0, 1, 3}) {
        const int d = (arrived + turn) % 4;
        const cv::Point next = node + kDirections[d];
        if (!bounds.contains(next)) continue;
        const int state = stateOf(next, d);
        const double next_cost = item.cost + 1.0 + (turn == 0 ? 0.0 : 0.4);
        if (next_cost < cost[state]) {
          cost[state] = next_cost;
          previous[state] = item.state;
          open.push({next_cost, state});
        }
      }
    }
    return {};
  }

  RouteSettings settings_;
  SeededRandom rng_;
  double radius_;
  int box_half_ = 2;
  std::vector<cv::Point> walk_;
  std::vector<double> length_at_;  // path length when each node is reached
  std::unordered_set<std::uint64_t> visited_;
  double length_ = 0;
  double revisit_length_ = 0;
  double first_repeat_length_ = -1;
};

}  // namespace

std::vector<cv::Point> planStreetWalk(const RouteSettings& settings) {
  if (!(settings.block > 0) || !(settings.length >= 0)) {
    throw Error(ErrorCode::kInvalidArgument, "synthetic route: block and length must be positive");
  }
  // The drive back to an old street comes on top of the first exploration; when it makes the
  // first repeat late, explore less and plan again.
  RouteSettings attempt = settings;
  const double wanted = settings.first_revisit_fraction * settings.length;
  std::vector<cv::Point> best;
  double best_error = 1e300;
  for (int round = 0; round < 4; ++round) {
    WalkPlanner planner(attempt);
    std::vector<cv::Point> walk = planner.plan();
    const double late = planner.firstRepeatLength() - wanted;
    const double error = planner.firstRepeatLength() < 0 ? 1e200 : std::abs(late);
    if (error < best_error) {
      best = std::move(walk);
      best_error = error;
    }
    if (planner.firstRepeatLength() < 0 || late < 0.05 * settings.length) break;
    attempt.first_revisit_fraction =
        std::max(0.0, attempt.first_revisit_fraction - late / std::max(1.0, settings.length));
  }
  return best;
}

double pathLength(const std::vector<cv::Point>& walk, double block, double turn_radius) {
  const double radius = std::min(turn_radius, 0.5 * block);
  double length = 0;
  for (std::size_t k = 1; k < walk.size(); ++k) {
    length += block;
    if (k >= 2 && walk[k] - walk[k - 1] != walk[k - 1] - walk[k - 2])
      length -= cornerSaving(radius);
  }
  return length;
}

std::vector<PathSample> samplePath(const std::vector<cv::Point>& walk, double block,
                                   double turn_radius, double spacing, int count) {
  if (walk.size() < 2) throw Error(ErrorCode::kInternal, "synthetic route: walk too short");
  const double radius = std::min(turn_radius, 0.5 * block);
  // Straight pieces and quarter circles, in driving order.
  struct Piece {
    cv::Point2d start;
    double start_heading;
    double length;
    double curvature;  // 1/radius, signed: positive turns left
  };
  std::vector<Piece> pieces;
  auto at = [&](std::size_t k) { return cv::Point2d(walk[k]) * block; };
  auto directionOf = [&](std::size_t k) {  // of edge k -> k+1
    return cv::Point2d(walk[k + 1] - walk[k]);
  };
  auto turnsAt = [&](std::size_t k) {  // whether the path turns at node k
    return k > 0 && k + 1 < walk.size() && walk[k + 1] - walk[k] != walk[k] - walk[k - 1];
  };
  for (std::size_t k = 0; k + 1 < walk.size(); ++k) {
    const cv::Point2d d = directionOf(k);
    const double heading = std::atan2(d.y, d.x);
    const double cut_in = turnsAt(k) ? radius : 0, cut_out = turnsAt(k + 1) ? radius : 0;
    pieces.push_back({at(k) + d * cut_in, heading, block - cut_in - cut_out, 0});
    if (turnsAt(k + 1)) {
      const cv::Point2d out = directionOf(k + 1);
      const double side = d.x * out.y - d.y * out.x;  // +1 left, -1 right
      pieces.push_back({at(k + 1) - d * radius, heading, 0.5 * CV_PI * radius, side / radius});
    }
  }
  std::vector<PathSample> samples;
  samples.reserve(count);
  std::size_t piece = 0;
  double piece_start = 0;
  double unwrap = 0;  // keeps heading continuous across pieces
  double last_heading = pieces[0].start_heading;
  for (int i = 0; i < count; ++i) {
    const double s = i * spacing;
    while (piece + 1 < pieces.size() && s > piece_start + pieces[piece].length) {
      piece_start += pieces[piece].length;
      ++piece;
    }
    const Piece& p = pieces[piece];
    const double along = s - piece_start;  // beyond the last piece: continue straight
    PathSample sample;
    double heading = p.start_heading;
    if (p.curvature == 0 || along > p.length) {
      const double straight = p.curvature == 0 ? along : along - p.length;
      cv::Point2d base = p.start;
      if (p.curvature != 0) {
        heading = p.start_heading + p.curvature * p.length;
        const double r = 1.0 / p.curvature;
        base = p.start + cv::Point2d(-std::sin(p.start_heading), std::cos(p.start_heading)) * r +
               cv::Point2d(std::sin(heading), -std::cos(heading)) * r;
      }
      sample.x = base.x + straight * std::cos(heading);
      sample.y = base.y + straight * std::sin(heading);
    } else {
      const double r = 1.0 / p.curvature;  // signed
      const cv::Point2d centre =
          p.start + cv::Point2d(-std::sin(p.start_heading), std::cos(p.start_heading)) * r;
      heading = p.start_heading + p.curvature * along;
      sample.x = centre.x + std::sin(heading) * r;
      sample.y = centre.y - std::cos(heading) * r;
    }
    // Keep heading continuous: atan2-based starts can jump by 2*pi between pieces.
    double step = heading + unwrap - last_heading;
    while (step > CV_PI) {
      unwrap -= 2 * CV_PI;
      step -= 2 * CV_PI;
    }
    while (step < -CV_PI) {
      unwrap += 2 * CV_PI;
      step += 2 * CV_PI;
    }
    sample.heading = heading + unwrap;
    last_heading = sample.heading;
    samples.push_back(sample);
  }
  return samples;
}

}  // namespace placedb::synthetic
