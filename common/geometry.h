// Rigid and similarity transforms and trajectory evaluation.
// Naming: a_from_b maps points in frame b to frame a (p_a = a_from_b * p_b). Lengths in mm unless stated.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <vector>

namespace objscan {

constexpr double kDegToRad = M_PI / 180.0;  // rad per degree

struct Sim3 {
  double scale = 1.0;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return scale * (rotation * p) + translation; }
  // Applies the similarity to a pose world_from_camera (scales the position, rotates the orientation).
  Eigen::Isometry3d Apply(const Eigen::Isometry3d& pose) const;
};

// Least-squares similarity (Umeyama 1991) with dst ≈ S * src; with_scale=false fixes scale to 1.
// Needs >= 3 non-collinear pairs; returns false otherwise.
bool AlignUmeyama(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst, bool with_scale,
                  Sim3* out);
// AlignUmeyama with scale, and *rms the RMS distance (input unit) of S * src to dst: how well one Sim(3) explains the
// pairs (a map moved as a whole). False as AlignUmeyama.
bool AlignSimilarity(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst, Sim3* out,
                     double* rms);

// Angle of a rotation matrix (rad), robust near 0 and pi.
double RotationAngle(const Eigen::Matrix3d& r);

struct TrajectoryError {
  int num_poses = 0;
  double ate_rmse = 0;          // same unit as the input positions, after alignment
  double ate_max = 0;
  double rotation_mean_rad = 0; // mean angle between aligned and true orientations
  double rotation_max_rad = 0;
  double scale = 1;             // scale of the alignment (estimated -> true)
  Sim3 alignment;               // true ≈ alignment * estimated
};

// Aligns estimated camera poses to true ones (pairs by index) with Sim(3) (or SE(3) when with_scale=false) over the
// camera centres and measures absolute trajectory error and rotation error. Returns false with fewer than 3 poses.
bool EvaluateTrajectory(const std::vector<Eigen::Isometry3d>& world_from_camera_estimated,
                        const std::vector<Eigen::Isometry3d>& world_from_camera_true, bool with_scale,
                        TrajectoryError* out);

// Quaternion (w, x, y, z) array helpers for message fields.
Eigen::Isometry3d PoseFromArrays(const double position[3], const double quaternion_wxyz[4]);
void PoseToArrays(const Eigen::Isometry3d& pose, double position[3], double quaternion_wxyz[4]);

}  // namespace objscan
