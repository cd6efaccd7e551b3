// Region of interest of the dense model (LCM-free): the part of the world (mm) where the object is.
// A region is an axis-aligned world box, optionally cut by a floor half-space: a point is inside when it lies in the
// box and at least floor_clearance_mm above the floor plane. Sources, in the node's order of preference: a
// confirmed TARGET box, a box from the configuration, or AutoRegionOfInterest() below, which derives it from the
// sparse landmarks of the pose solver:
//   1. central landmarks = landmarks whose track was seen inside the central window of at least min_central_views
//      posed frames (the pan-tilt camera keeps the object near the optical axis; track ids make this
//      occlusion-aware, unlike projecting landmarks);
//   2. floor = the plane with the most landmarks within floor_tolerance_mm among the landmarks within floor_radius_mm
//      (horizontally) of the central landmarks' median, normal within max_floor_tilt_deg of world +z (deterministic
//      RANSAC + least-squares refit, common/floor_fit.h). The pose solver's world frame is z-up but its floor is
//      only approximately z = 0 (6-DOF: odometry frame of the first posed frame; see
//      processes/pose_solver/pose_estimator.h), so the plane is measured, never assumed;
//   3. central landmarks less than floor_clearance_mm above the floor are dropped; the rest are clustered robustly
//      (distance to their coordinate-wise median <= cluster_k x the median distance);
//   4. box = bounding box of the cluster, grown on every side by max(margin_mm, margin_fraction x its extent).
// Deterministic: the same input gives the same region.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <unordered_map>
#include <vector>

#include "common/camera_model.h"
#include "common/floor_fit.h"
#include "common/geometry.h"

namespace objscan {

struct RegionOfInterest {
  bool valid = false;                                       // false = no restriction known
  Eigen::Vector3d box_min = Eigen::Vector3d::Zero();        // mm, world
  Eigen::Vector3d box_max = Eigen::Vector3d::Zero();        // mm, world
  bool has_floor = false;                                   // the floor half-space applies
  FloorPlane floor;                                         // world: height of x = floor.Height(x), mm, up > 0
  double floor_clearance_mm = 0.0;                          // mm, points lower than this above the floor are outside

  // Height of x above the floor (mm; +infinity when there is no floor).
  double HeightAboveFloor(const Eigen::Vector3d& x) const;
  // True when x is inside (always true for an invalid region).
  bool Contains(const Eigen::Vector3d& x) const;
  // True when every point of the convex hull of the three points is surely outside, by more than slack_mm: all
  // three beyond the same box face, or all lower than clearance - slack above the floor. (Always false for an
  // invalid region.)
  bool TriangleOutside(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& p2,
                       double slack_mm) const;
  // True when every vertex lies on the floor: less than half the floor clearance above it (or below it), the floor
  // vertex of TriangleSpansFloorJunction. False for an invalid region, without a floor or with a clearance <= 0
  // (the floor is then kept).
  bool TriangleOnFloor(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& p2) const;
  // True when the triangle joins the floor to the object: one vertex lies on the floor (less than half the floor
  // clearance above it) and another is above the clearance. Its interior is not a surface but the air of the
  // crevice between them (the affine map would put points there). False without a floor.
  bool TriangleSpansFloorJunction(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                                  const Eigen::Vector3d& p2) const;
  // Pixel rectangle of the box seen by the camera (bounding rectangle of the projected corners, grown by
  // margin_px, clipped to the image). Whole image when the region is invalid or a corner is not in front of the
  // camera; empty when the box is behind the camera or off the image.
  cv::Rect ImageRect(const PinholeCamera& camera, const Eigen::Isometry3d& world_from_camera, double margin_px) const;
};

struct AutoRoiOptions {
  double central_fraction = 0.3;     // central window = this fraction of the image width and height, centred on
                                     // the principal point, (0, 1]
  int min_central_views = 1;         // views in which a landmark's track must lie in the central window (>= 1)
  int min_central_landmarks = 15;    // fewer central landmarks (after floor removal) = no region (>= 3)
  double cluster_k = 2.5;            // cluster = central landmarks within cluster_k x median distance of the median
  double margin_mm = 30.0;           // mm, minimum growth of the box on every side (>= 0)
  double margin_fraction = 0.25;     // box grows by this fraction of its extent on every side when larger (>= 0)
  bool detect_floor = true;          // look for the floor plane among the landmarks
  double floor_radius_mm = 600.0;    // mm, horizontal radius around the central median searched for the floor (> 0)
  double floor_tolerance_mm = 5.0;   // mm, plane inlier distance (> 0)
  int min_floor_points = 30;         // landmarks needed to accept a floor plane (>= 3)
  double max_floor_tilt_deg = 20.0;  // deg, max angle between the floor normal and world +z, (0, 90)
  double floor_clearance_mm = 4.0;   // mm, points lower than this above the floor are outside the region (>= 0);
                                     // floor just above it is dropped later as surface facing up (floor_band_mm)
  int ransac_iterations = 300;       // floor RANSAC samples (>= 1)
};

bool ValidateAutoRoiOptions(const AutoRoiOptions& options, std::string* why);

// Counts, per track id, the views in which the track lies in the central window of the image (camera's size).
void CountCentralTracks(const PinholeCamera& camera, const std::vector<std::pair<int64_t, Eigen::Vector2d>>& tracks,
                        double central_fraction, std::unordered_map<int64_t, int>* counts);

// The dense modeler's floor policy: the plane with the most points. Deterministic RANSAC (common/floor_fit.h
// MostSupportedPlane: `iterations` 3-point samples, LCG sequence, fixed seed) for the plane with the most points (mm, world)
// within tolerance_mm whose normal is within max_tilt_deg of +z, refitted twice by total least squares to its
// inliers (a refit tilted more than max_tilt_deg is not taken). False (*floor unchanged) when fewer than min_points
// inliers. floor->plane: common/floor_fit.h's FloorPlane, as RegionOfInterest::floor.
bool FitFloorPlane(const std::vector<Eigen::Vector3d>& points, double tolerance_mm, double max_tilt_deg, int min_points,
                   int iterations, PlaneSupport* floor);

// Fits the floor (FitFloorPlane with the options' floor settings) to the landmarks within floor_radius_mm
// (horizontally) of centre and, when found, sets the floor half-space of *region (clearance floor_clearance_mm).
// Returns the number of floor inliers (0 = no floor; *region unchanged).
int AddFloorNear(const std::vector<Eigen::Vector3d>& landmarks, const Eigen::Vector3d& centre,
                 const AutoRoiOptions& options, RegionOfInterest* region);

struct AutoRoiStats {
  int landmarks = 0;      // landmarks given
  int central = 0;        // central landmarks (step 1)
  int floor_inliers = 0;  // 0 when no floor was found
  int above_floor = 0;    // central landmarks left after step 3's floor removal
  int cluster = 0;        // landmarks in the cluster
};

// The automatic region (see the file comment). landmark ids index central_counts (track id -> central views).
// False (and *roi invalid) when there are not enough central landmarks.
bool AutoRegionOfInterest(const std::vector<int64_t>& landmark_ids, const std::vector<Eigen::Vector3d>& landmarks,
                          const std::unordered_map<int64_t, int>& central_counts, const AutoRoiOptions& options,
                          RegionOfInterest* roi, AutoRoiStats* stats = nullptr);

// Parses "xmin,ymin,zmin,xmax,ymax,zmax" (mm). "" gives an invalid region and true. False with *why when malformed
// or min >= max on an axis.
bool ParseRoiBox(const std::string& text, RegionOfInterest* roi, std::string* why);

// The region carried by a similarity x' = sim * x (the map moved as a whole: the final poses are the live ones moved
// by a Sim(3)): the box becomes the axis-aligned box around its 8 moved corners, the floor plane moves with it and the
// clearance scales. An invalid region stays invalid.
RegionOfInterest TransformRegion(const RegionOfInterest& region, const Sim3& sim);

}  // namespace objscan
