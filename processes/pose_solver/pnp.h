// Camera pose from known 3-D landmarks: RANSAC P3P (cv::solvePnPRansac, SOLVEPNP_AP3P, cv::theRNG seeded before
// every call for determinism) over 2-D/3-D correspondences, then Ceres refinement (robust Huber loss) of the
// 6-DOF pose or of the robot's 4-DOF pose (bundle_adjustment.h), re-selection of inliers at the final threshold and a
// second refinement. Pixels are UNDISTORTED. LCM-free. Does not throw (OpenCV errors become a false return).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "common/camera_model.h"
#include "common/robot_model.h"
#include "processes/pose_solver/bundle_adjustment.h"

namespace objscan {

struct PnpOptions {
  MotionModel model = MotionModel::kSixDof;  // refinement parameterization
  int ransac_iterations = 100;               // RANSAC hypotheses
  double ransac_threshold_px = 4.0;          // px, RANSAC inlier threshold
  double inlier_threshold_px = 2.5;          // px, inlier threshold after refinement
  int min_inliers = 15;                      // fewer final inliers = failure
  double loss_scale_px = 1.0;                // px, Huber scale of the refinement
  int refine_iterations = 10;                // Ceres iterations per refinement
  uint64_t seed = 1;                         // cv::theRNG seed set before each RANSAC call
  bool use_prior_first = true;               // try refining the prior pose before RANSAC (fast path)
};

struct PnpResult {
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();  // mm
  std::vector<int> inliers;                                             // indices into the correspondences
  double rms_px = 0;                                                    // RMS over the inliers
  bool used_ransac = false;                                             // false when the prior-pose fast path succeeded
};

// points_in_world[i] <-> pixels[i]. prior (may be null): a pose close to the answer (e.g. the previous frame's);
// with use_prior_first, it is refined directly and RANSAC runs only when that leaves too few inliers.
bool SolvePnp(const PinholeCamera& camera, const RobotGeometry& robot,
              const std::vector<Eigen::Vector3d>& points_in_world, const std::vector<Eigen::Vector2d>& pixels,
              const Eigen::Isometry3d* prior, const PnpOptions& options, PnpResult* result, std::string* why = nullptr);

}  // namespace objscan
