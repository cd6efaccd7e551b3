// Pinhole camera with optional OpenCV plumb_bob distortion (k1 k2 p1 p2 k3).
// Frames: camera x right, y down, z forward. Pixels: (u, v) = (column, row), origin at the top-left pixel's centre.
#pragma once

#include <Eigen/Core>
#include <string>

namespace objscan {

struct PinholeCamera {
  std::string name;       // camera name
  int width = 0;          // px
  int height = 0;         // px
  double fx = 0, fy = 0;  // px
  double cx = 0, cy = 0;  // px
  double skew = 0;        // px
  // k1 k2 p1 p2 k3 (OpenCV); all zero = no distortion.
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;

  bool HasDistortion() const { return k1 != 0 || k2 != 0 || p1 != 0 || p2 != 0 || k3 != 0; }
  // True when the numbers can describe a camera (positive size and focal lengths, finite values).
  bool IsValid(std::string* why = nullptr) const;
  Eigen::Matrix3d K() const;

  // Projects a point in the camera frame (mm or any unit) to a distorted pixel. False when z <= 0. Inline (per-pixel
  // loops call it); distortion goes through Distort.
  bool Project(const Eigen::Vector3d& point_in_camera, Eigen::Vector2d* pixel) const {
    if (!(point_in_camera.z() > 0)) return false;
    const Eigen::Vector2d n(point_in_camera.x() / point_in_camera.z(), point_in_camera.y() / point_in_camera.z());
    const Eigen::Vector2d d = HasDistortion() ? Distort(n) : n;
    *pixel = Eigen::Vector2d(fx * d.x() + skew * d.y() + cx, fy * d.y() + cy);
    return true;
  }
  // Normalized image coordinates (x/z, y/z) of a distorted pixel (undistorts iteratively). Inline like Project.
  Eigen::Vector2d Unproject(const Eigen::Vector2d& pixel) const {
    const double yd = (pixel.y() - cy) / fy;
    const double xd = (pixel.x() - cx - skew * yd) / fx;
    return HasDistortion() ? Undistort(Eigen::Vector2d(xd, yd)) : Eigen::Vector2d(xd, yd);
  }
  // Undistorts distorted normalized coordinates (fixed-point iteration; the inverse of Distort).
  Eigen::Vector2d Undistort(const Eigen::Vector2d& distorted) const;
  // Distorts normalized coordinates (no-op without distortion).
  Eigen::Vector2d Distort(const Eigen::Vector2d& normalized) const;
  bool InImage(const Eigen::Vector2d& pixel, double margin = 0) const {
    return pixel.x() >= -0.5 + margin && pixel.y() >= -0.5 + margin && pixel.x() <= width - 0.5 - margin &&
           pixel.y() <= height - 0.5 - margin;
  }
};

// True when b has a's size, intrinsics and distortion exactly (the name aside). Every process keeps the first
// camera_info it accepts and rejects a different later one (a second camera or session on the bus, or a forged
// message: the fuzz test's fx = 500 had replaced the dense modeler's calibration).
bool SameCalibration(const PinholeCamera& a, const PinholeCamera& b);

// IsValid plus the principal point inside the image (a metric calibration). False with *why.
bool CheckMetricCamera(const PinholeCamera& camera, std::string* why);

// Reads an OpenCV FileStorage calibration (YAML/XML/JSON): camera_matrix (3x3; OpenCV matrix, ROS-style map with
// "data", or a plain list), distortion_coefficients (0, 4 or 5 values, OpenCV order k1 k2 p1 p2 k3; more only when
// the extra ones are zero), image_width, image_height. Checks that the numbers describe a camera (positive size and
// focal lengths, K's last row 0 0 1, principal point inside the image). The camera gets camera_name. Returns false
// with *error naming the file and the problem; never throws.
bool ReadCalibrationFile(const std::string& path, const std::string& camera_name, PinholeCamera* camera,
                         std::string* error);

// Writes an OpenCV FileStorage calibration (YAML): image_width, image_height, camera_matrix (3x3) and
// distortion_coefficients (k1 k2 p1 p2 k3) — the dataset folder's calib.yaml, read back by ReadCalibrationFile.
// False with *error when the file cannot be written.
bool WriteCalibrationFile(const std::string& path, const PinholeCamera& camera, std::string* error);

}  // namespace objscan
