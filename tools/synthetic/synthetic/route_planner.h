#pragma once
// The camera's route: a drive along a grid of streets that explores new blocks and, on a
// schedule, drives again down streets it took before, in the same direction.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace placedb::synthetic {

struct RouteSettings {
  std::uint64_t seed = 1;
  double length = 180;                   // metres the camera must be able to drive
  double block = 20;                     // metres between intersections
  double turn_radius = 7;                // metres; corners are quarter circles
  double revisit_fraction = 0.4;         // share of the length planned as repeated streets
  double first_revisit_fraction = 0.35;  // share of the length explored before the first repeat
  double min_gap_length = 30;            // a repeated street was driven at least this long ago
  int revisit_chunk_edges[2] = {2, 5};   // street edges per repeat, inclusive range
  int explore_chunk_edges[2] = {1, 3};   // street edges per exploration spell
  int nearest_of = 6;                    // repeat the closest of this many random old stretches
};

// Grid nodes (in units of `block`) the route passes; consecutive nodes are neighbours and the
// route never reverses. Long enough for settings.length once corners are cut.
std::vector<cv::Point> planStreetWalk(const RouteSettings& settings);

struct PathSample {
  double x = 0, y = 0;  // metres
  double heading = 0;   // radians, continuous (not wrapped)
};

// `count` points spaced `spacing` metres apart along the walk, corners rounded with quarter
// circles of radius min(turn_radius, block / 2).
std::vector<PathSample> samplePath(const std::vector<cv::Point>& walk, double block,
                                   double turn_radius, double spacing, int count);

// Length of the rounded path through the walk.
double pathLength(const std::vector<cv::Point>& walk, double block, double turn_radius);

}  // namespace placedb::synthetic
