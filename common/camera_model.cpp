#include "common/camera_model.h"

#include <cmath>
#include <filesystem>
#include <opencv2/core.hpp>
#include <sstream>
#include <vector>

namespace objscan {
namespace {

bool Fail(std::string* error, const std::string& text) {
  if (error) *error = text;
  return false;
}

// Reads a 3x3 / 1xN matrix node: OpenCV "!!opencv-matrix" or a ROS-style map with a "data" list, or a plain list.
bool ReadMatrixNode(const cv::FileNode& node, cv::Mat* out) {
  try {
    if (node.isMap() && !node["data"].empty() && node["dt"].empty()) {
      std::vector<double> data;
      node["data"] >> data;
      int rows = 1, cols = static_cast<int>(data.size());
      if (!node["rows"].empty() && !node["cols"].empty()) {
        rows = static_cast<int>(node["rows"]);
        cols = static_cast<int>(node["cols"]);
      }
      if (rows * cols != static_cast<int>(data.size())) return false;
      *out = cv::Mat(data, true).reshape(1, rows);
      return true;
    }
    if (node.isSeq()) {
      std::vector<double> data;
      node >> data;
      *out = cv::Mat(data, true).reshape(1, 1);
      return true;
    }
    cv::Mat m;
    node >> m;
    if (m.empty()) return false;
    m.convertTo(*out, CV_64F);
    return true;
  } catch (const cv::Exception&) {
    return false;
  }
}

bool ReadIntNode(const cv::FileNode& node, int* out) {
  if (node.empty() || !(node.isInt() || node.isReal())) return false;
  const double v = static_cast<double>(node);
  if (v != std::floor(v)) return false;
  *out = static_cast<int>(v);
  return true;
}

}  // namespace

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

Eigen::Vector2d PinholeCamera::Undistort(const Eigen::Vector2d& distorted) const {
  Eigen::Vector2d n = distorted;
  if (!HasDistortion()) return n;
  // Fixed-point iteration: n = d - (Distort(n) - n), converges for moderate distortion.
  for (int i = 0; i < 20; ++i) {
    const Eigen::Vector2d err = Distort(n) - distorted;
    n -= err;
    if (err.squaredNorm() < 1e-24) break;
  }
  return n;
}

bool CheckMetricCamera(const PinholeCamera& c, std::string* why) {
  if (!c.IsValid(why)) return false;
  if (c.cx < -0.5 || c.cx > c.width - 0.5 || c.cy < -0.5 || c.cy > c.height - 0.5) {
    std::ostringstream os;
    os << "principal point (" << c.cx << ", " << c.cy << ") lies outside the " << c.width << "x" << c.height
       << " image (not a metric calibration?)";
    if (why) *why = os.str();
    return false;
  }
  return true;
}

bool ReadCalibrationFile(const std::string& path, const std::string& camera_name, PinholeCamera* camera,
                         std::string* error) {
  if (!std::filesystem::is_regular_file(path)) return Fail(error, "calibration file " + path + " not found");
  cv::FileStorage storage;
  try {
    if (!storage.open(path, cv::FileStorage::READ) || !storage.isOpened())
      return Fail(error, "calibration file " + path + " cannot be parsed");
  } catch (const cv::Exception& e) {
    return Fail(error, "calibration file " + path + " cannot be parsed: " + e.what());
  }
  const std::string where = "calibration " + path;
  cv::Mat k;
  if (storage["camera_matrix"].empty()) return Fail(error, where + ": missing camera_matrix");
  if (!ReadMatrixNode(storage["camera_matrix"], &k) || k.total() != 9)
    return Fail(error, where + ": camera_matrix must be a 3x3 matrix");
  k = k.reshape(1, 3);
  if (k.at<double>(1, 0) != 0 || k.at<double>(2, 0) != 0 || k.at<double>(2, 1) != 0 || k.at<double>(2, 2) != 1)
    return Fail(error, where + ": camera_matrix must look like [fx s cx; 0 fy cy; 0 0 1]");
  PinholeCamera c;
  c.name = camera_name;
  if (!ReadIntNode(storage["image_width"], &c.width) || !ReadIntNode(storage["image_height"], &c.height))
    return Fail(error, where + ": missing or non-integer image_width / image_height");
  c.fx = k.at<double>(0, 0);
  c.skew = k.at<double>(0, 1);
  c.cx = k.at<double>(0, 2);
  c.fy = k.at<double>(1, 1);
  c.cy = k.at<double>(1, 2);
  const cv::FileNode dist_node = storage["distortion_coefficients"];
  if (!dist_node.empty()) {
    cv::Mat d;
    if (!ReadMatrixNode(dist_node, &d)) return Fail(error, where + ": distortion_coefficients is not a vector");
    d = d.reshape(1, 1);
    const int n = static_cast<int>(d.total());
    if (n != 0 && n != 4 && n < 5) return Fail(error, where + ": distortion_coefficients needs 0, 4 or 5 values");
    for (int i = 5; i < n; ++i)
      if (d.at<double>(0, i) != 0)
        return Fail(error, where + ": only plumb_bob distortion (k1 k2 p1 p2 k3) is supported, coefficient " +
                               std::to_string(i + 1) + " is not zero");
    double* coeffs[5] = {&c.k1, &c.k2, &c.p1, &c.p2, &c.k3};
    for (int i = 0; i < n && i < 5; ++i) *coeffs[i] = d.at<double>(0, i);
  }
  std::string why;
  if (!CheckMetricCamera(c, &why)) return Fail(error, where + ": " + why);
  *camera = c;
  return true;
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

bool SameCalibration(const PinholeCamera& a, const PinholeCamera& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy &&
         a.skew == b.skew && a.k1 == b.k1 && a.k2 == b.k2 && a.p1 == b.p1 && a.p2 == b.p2 && a.k3 == b.k3;
}

}  // namespace objscan
