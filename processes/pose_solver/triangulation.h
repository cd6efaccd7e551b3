// Multi-view triangulation of one point: linear DLT over all views, Gauss–Newton refinement of the reprojection
// error, then acceptance tests (positive depth in every view, parallax angle, reprojection error in EVERY view
// below the threshold). Pixels are UNDISTORTED (see bundle_adjustment.h UndistortPixel). LCM-free, deterministic.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "common/camera_model.h"

namespace objscan {

struct TriangulationOptions {
  int min_views = 2;                 // views needed
  double min_parallax_deg = 2.0;     // deg, largest angle between two viewing rays must reach this
  double max_reprojection_px = 2.0;  // px, every view's error must stay below this
  int refine_iterations = 5;         // Gauss–Newton iterations after the DLT
};

struct TriangulatedPoint {
  Eigen::Vector3d point_in_world = Eigen::Vector3d::Zero();  // mm
  double rms_px = 0;                                         // RMS reprojection error over the views
  double max_error_px = 0;                                   // worst view
  double parallax_deg = 0;                                   // largest ray angle
};

// Returns false with *why ("too few views", "low parallax", "behind camera", "reprojection") when rejected.
bool TriangulatePoint(const PinholeCamera& camera, const std::vector<Eigen::Isometry3d>& world_from_camera,
                      const std::vector<Eigen::Vector2d>& pixels, const TriangulationOptions& options,
                      TriangulatedPoint* out, std::string* why = nullptr);

}  // namespace objscan
