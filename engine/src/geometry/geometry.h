#pragma once
// Geometric verification, as the rest of the engine calls it: is a candidate place a view of the
// same rigid scene as the frame (checkGeometry and its settings and result), the keypoints a
// location brings to that check (KeypointCache, and the view of its latest merged frame:
// latest_view.h), and the relative pose a verified closure gives (relativePose).
// Correspondences (descriptor_match.h) and the 7-point RANSAC (epipolar_fit.h) are this room's
// own steps.
#include "geometry/geometric_check.h"
#include "geometry/keypoint_cache.h"
#include "geometry/latest_view.h"
#include "geometry/relative_pose.h"
#include "geometry/scene_extent.h"
