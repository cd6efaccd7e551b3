#include "common/camera_model.h"

#include <cmath>
#include <opencv2/core.hpp>

namespace objscan {

bool PinholeCamera::IsValid(std::string* why) const {
  auto fail = [why](const char* text) {
    if (why) *why = text;
    return false;
  };
  if (width <= 0 || height <= 0) return fail("image size must be positive");
  if (!(fx > 0) || !(fy > 0) || !std::isfinite(fx) || !std::isfinite(fy)) return fail("focal lengths must be > 0");
  if (!std::isfinite(cx) || !std::isfinite(cy) || !std::isfinite(skew)) return fail("principal point not finite");
  for (double d : {k1, k2, p1, p2, k3})
    if (!std::isfinite(d)) return fail("distortion not finite");
  return true;
}

Eigen::Matrix3d PinholeCamera::K() const {
  Eigen::Matrix3d k;
  k << fx, skew, cx, 0, fy, cy, 0, 0, 1;
  return k;
}

Eigen::Vector2d PinholeCamera::Distort(const Eigen::Vector2d& n) const {
  if (!HasDistortion()) return n;
  const double x = n.x(), y = n.y();
  const double r2 = x * x + y * y;
  const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
  return {x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x), y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y};
}

bool PinholeCamera::Project(const Eigen::Vector3d& p, Eigen::Vector2d* pixel) const {
  if (!(p.z() > 0)) return false;
  const Eigen::Vector2d d = Distort(Eigen::Vector2d(p.x() / p.z(), p.y() / p.z()));
  *pixel = Eigen::Vector2d(fx * d.x() + skew * d.y() + cx, fy * d.y() + cy);
  return true;
}

Eigen::Vector2d PinholeCamera::Unproject(const Eigen::Vector2d& pixel) const {
  const double yd = (pixel.y() - cy) / fy;
  const double xd = (pixel.x() - cx - skew * yd) / fx;
  Eigen::Vector2d n(xd, yd);
  if (!HasDistortion()) return n;
  // Fixed-point iteration: n = d - (Distort(n) - n), converges for moderate distortion.
  for (int i = 0; i < 20; ++i) {
    const Eigen::Vector2d err = Distort(n) - Eigen::Vector2d(xd, yd);
    n -= err;
    if (err.squaredNorm() < 1e-24) break;
  }
  return n;
}

bool WriteCalibrationFile(const std::string& path, const PinholeCamera& camera, std::string* error) {
  try {
    cv::FileStorage storage(path, cv::FileStorage::WRITE);
    if (!storage.isOpened()) {
      if (error) *error = "cannot write " + path;
      return false;
    }
    const cv::Mat k = (cv::Mat_<double>(3, 3) << camera.fx, camera.skew, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
    const cv::Mat d = (cv::Mat_<double>(1, 5) << camera.k1, camera.k2, camera.p1, camera.p2, camera.k3);
    storage << "image_width" << camera.width << "image_height" << camera.height << "camera_matrix" << k
            << "distortion_coefficients" << d;
  } catch (const cv::Exception& e) {
    if (error) *error = "cannot write " + path + ": " + e.what();
    return false;
  }
  return true;
}

}  // namespace objscan
