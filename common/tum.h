// TUM trajectories, the one reader and writer of the project's trajectory files (trajectory.txt, the simulator's
// poses_gt.txt, image sets' ground truth): one pose per line "t tx ty tz qx qy qz qw" (t in s; the camera-to-world
// pose world_from_camera, quaternion x y z w), '#' comment lines; positions in the file's unit (objscan: mm). No LCM.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace objscan {

struct StampedPose {
  double t = 0;  // s
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
};

// Reads a TUM file: every other line exactly 8 finite numbers, the quaternion of unit norm within 1e-3 (normalized).
// *units_mm (may be null): true when a comment line says "units: mm" (spaces and case ignored). False with
// *error = "path:line: why" on an unreadable file or a malformed line.
bool ReadTumTrajectory(const std::string& path, std::vector<StampedPose>* poses, std::string* error,
                       bool* units_mm = nullptr);

// Writes header lines (each as "# " + line), then one line per pose: t with 6 decimals, positions with
// position_decimals, the quaternion with 9; position_decimals < 0: positions and quaternion with 17 significant
// digits (they read back exactly). False with *error when the file cannot be written.
bool WriteTumTrajectory(const std::string& path, const std::vector<StampedPose>& poses,
                        const std::vector<std::string>& header, std::string* error, int position_decimals = 6);

}  // namespace objscan
