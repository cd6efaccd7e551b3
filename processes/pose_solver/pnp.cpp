#include "processes/pose_solver/pnp.h"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

namespace objscan {

namespace {
bool Fail(std::string* why, const std::string& reason) {
  if (why) *why = reason;
  return false;
}

std::vector<int> Inliers(const PinholeCamera& camera, const std::vector<Eigen::Vector3d>& points,
                         const std::vector<Eigen::Vector2d>& pixels, const Eigen::Isometry3d& world_from_camera,
                         double threshold, double* rms) {
  const Eigen::Isometry3d cw = world_from_camera.inverse();
  std::vector<int> in;
  double sum = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector2d uv;
    if (!ProjectIdeal(camera, cw * points[i], &uv)) continue;
    const double e2 = (uv - pixels[i]).squaredNorm();
    if (e2 <= threshold * threshold) {
      in.push_back(static_cast<int>(i));
      sum += e2;
    }
  }
  if (rms) *rms = in.empty() ? 0.0 : std::sqrt(sum / in.size());
  return in;
}

// Refines the pose on the given correspondences (points held fixed).
bool Refine(const PinholeCamera& camera, const RobotGeometry& robot, const std::vector<Eigen::Vector3d>& points,
            const std::vector<Eigen::Vector2d>& pixels, const std::vector<int>& use, const PnpOptions& options,
            Eigen::Isometry3d* pose) {
  BaOptions bo;
  bo.model = options.model;
  bo.loss_scale_px = options.loss_scale_px;
  bo.max_iterations = options.refine_iterations;
  return RefinePose(camera, robot, bo, points, pixels, use, pose);
}

bool RefineAndSelect(const PinholeCamera& camera, const RobotGeometry& robot,
                     const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector2d>& pixels,
                     std::vector<int> use, const PnpOptions& options, Eigen::Isometry3d pose, PnpResult* result) {
  for (int round = 0; round < 2; ++round) {
    if (static_cast<int>(use.size()) < options.min_inliers) return false;
    if (!Refine(camera, robot, points, pixels, use, options, &pose)) return false;
    std::vector<int> next = Inliers(camera, points, pixels, pose, options.inlier_threshold_px, &result->rms_px);
    const bool same = next == use;
    use.swap(next);
    if (same) break;
  }
  if (static_cast<int>(use.size()) < options.min_inliers) return false;
  result->world_from_camera = pose;
  result->inliers = use;
  return true;
}
}  // namespace

bool SolvePnp(const PinholeCamera& camera, const RobotGeometry& robot, const std::vector<Eigen::Vector3d>& points,
              const std::vector<Eigen::Vector2d>& pixels, const Eigen::Isometry3d* prior, const PnpOptions& options,
              PnpResult* result, std::string* why) {
  const size_t n = points.size();
  if (n != pixels.size()) return Fail(why, "pnp: size mismatch");
  if (static_cast<int>(n) < std::max(4, options.min_inliers)) return Fail(why, "pnp: too few correspondences");
  if (prior && options.use_prior_first) {
    // Fast path: inliers of the prior at the RANSAC threshold, refined.
    const std::vector<int> in = Inliers(camera, points, pixels, *prior, options.ransac_threshold_px, nullptr);
    if (static_cast<int>(in.size()) >= std::max<int>(options.min_inliers, static_cast<int>(0.5 * n))) {
      PnpResult r;
      if (RefineAndSelect(camera, robot, points, pixels, in, options, *prior, &r) &&
          static_cast<int>(r.inliers.size()) >= static_cast<int>(0.5 * n)) {
        r.used_ransac = false;
        *result = std::move(r);
        return true;
      }
    }
  }
  std::vector<cv::Point3d> object(n);
  std::vector<cv::Point2d> image(n);
  for (size_t i = 0; i < n; ++i) {
    object[i] = cv::Point3d(points[i].x(), points[i].y(), points[i].z());
    image[i] = cv::Point2d(pixels[i].x(), pixels[i].y());
  }
  cv::Mat k;
  cv::eigen2cv(camera.K(), k);
  cv::Mat rvec, tvec;
  std::vector<int> ransac_inliers;
  try {
    cv::theRNG().state = options.seed;
    const bool ok =
        cv::solvePnPRansac(object, image, k, cv::noArray(), rvec, tvec, false, options.ransac_iterations,
                           static_cast<float>(options.ransac_threshold_px), 0.999, ransac_inliers, cv::SOLVEPNP_AP3P);
    if (!ok) return Fail(why, "pnp: ransac failed");
  } catch (const cv::Exception& e) {
    return Fail(why, std::string("pnp: opencv: ") + e.what());
  }
  cv::Mat rm;
  cv::Rodrigues(rvec, rm);
  Eigen::Matrix3d r;
  cv::cv2eigen(rm, r);
  Eigen::Isometry3d cw = Eigen::Isometry3d::Identity();
  cw.linear() = r;
  cw.translation() = Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  const Eigen::Isometry3d pose = cw.inverse();
  if (!pose.matrix().allFinite()) return Fail(why, "pnp: non-finite ransac pose");
  std::vector<int> in = Inliers(camera, points, pixels, pose, options.ransac_threshold_px, nullptr);
  PnpResult out;
  if (!RefineAndSelect(camera, robot, points, pixels, in, options, pose, &out))
    return Fail(why, "pnp: too few inliers");
  out.used_ransac = true;
  *result = std::move(out);
  return true;
}

}  // namespace objscan
