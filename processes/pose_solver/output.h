// File writers for the pose solver's results (LCM-free). All return false (with *error) when the file cannot be
// written; they never throw.
//  - TUM trajectory: "t tx ty tz qx qy qz qw" per line, t = utime / 1e6 s, camera-to-world (world_from_camera),
//    positions in MILLIMETRES (stated in the '#' header; evo users: --t_max_diff default is fine, scale with 1e-3).
//  - Landmarks PLY (ASCII): x y z (mm, world) float, red green blue uchar, nobs int, error float (px).
//  - COLMAP text model (cameras.txt PINHOLE or OPENCV, images.txt with cam_from_world quaternion qw qx qy qz and
//    translation, 2-D points with POINT3D_ID, points3D.txt with tracks), positions in mm.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/camera_model.h"
#include "common/sensor_data.h"
#include "processes/pose_solver/pose_estimator.h"

namespace objscan {

// Writes poses whose status is in `statuses` (default: tracking and relocalized).
bool WriteTumTrajectory(const std::string& path, const std::vector<CameraPoseEstimate>& poses, std::string* error,
                        bool include_all_statuses = false);
bool WriteLandmarksPly(const std::string& path, const std::vector<Landmark>& landmarks, std::string* error);

// One image of the COLMAP model: its pose and its 2-D observations (undistorted or raw pixels as measured).
struct ColmapImage {
  CameraPoseEstimate pose;
  std::string name;                       // image file name, e.g. "000012.png"
  std::vector<TrackedFeature> features;   // observations (track id = POINT3D_ID when a landmark has that id)
};
// Writes dir/cameras.txt, dir/images.txt, dir/points3D.txt (dir is created). Only images with a tracking or
// relocalized pose are written; point tracks list (IMAGE_ID, POINT2D_IDX) of those images.
bool WriteColmapText(const std::string& dir, const PinholeCamera& camera, const std::vector<ColmapImage>& images,
                     const std::vector<Landmark>& landmarks, std::string* error);

// Reads a TUM file written by WriteTumTrajectory back (for tests/tools): utime (rounded from t) and pose.
bool ReadTumTrajectory(const std::string& path, std::vector<CameraPoseEstimate>* poses, std::string* error);

}  // namespace objscan
