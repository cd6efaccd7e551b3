// Clusters of map points above the floor and the boxes that bound them. LCM-free, deterministic, mm / rad.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "processes/object_finder/floor_plane.h"

namespace objscan {

// Single-linkage Euclidean clustering: two points closer than distance_mm (3-D) are in the same cluster. A hash grid
// of cell distance_mm keeps it near O(points). Returns the clusters with at least min_points members, each a sorted
// list of indices into points, ordered by their first index (independent of hash order).
std::vector<std::vector<int>> EuclideanClusters(const std::vector<Eigen::Vector3d>& points, double distance_mm,
                                                int min_points);

// Minimum-area rectangle around 2-D points (rotating calipers over the convex hull). yaw_rad is the angle of the
// rectangle's first axis, normalised to [-pi/4, pi/4) with extents swapped to match; extents along (first, second)
// axis. Fewer than 3 distinct hull points: the axis-aligned bounding box.
struct Rectangle2d {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  Eigen::Vector2d extents = Eigen::Vector2d::Zero();
  double yaw_rad = 0;
};
Rectangle2d MinAreaRectangle(const std::vector<Eigen::Vector2d>& points);

// The box of one cluster, measured in the floor's frame (FloorPlane::FloorFromWorld) and given in world.
struct ClusterBox {
  Eigen::Vector3d centre_mm = Eigen::Vector3d::Zero();  // world: rectangle centre at mid height above the floor
  Eigen::Vector3d size_mm = Eigen::Vector3d::Zero();    // extents along the box axes (yaw) and height above floor
  double yaw_rad = 0;                                   // about the floor normal (~ world z), [-pi/4, pi/4)
  double lowest_mm = 0;                                 // mm, lowest member's height above the floor
  int points = 0;                                       // members
  // members per 100 cm^2 of the box's visible side area (x + y) * height + x * y: two adjacent sides and the
  // top, what one view of a box shows at most.
  double texture_density = 0;
  double median_error_px = 0;  // px, members' median reprojection error (0 without errors)
};

// floor_points: the members' positions in the floor frame (z = height above the floor). The footprint is robust to
// stray members from 50 points on (yaw without the farthest 2 %, extents between the 1 % and 99 % quantiles);
// the height is the highest member's. errors_px (optional, parallel to floor_points): the points' reprojection
// errors, whose median over the members becomes median_error_px.
ClusterBox FitClusterBox(const std::vector<Eigen::Vector3d>& floor_points, const std::vector<int>& members,
                         const FloorPlane& floor, const std::vector<double>* errors_px = nullptr);

}  // namespace objscan
