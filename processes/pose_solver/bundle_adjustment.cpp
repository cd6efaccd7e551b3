#include "processes/pose_solver/bundle_adjustment.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <cmath>
#include <memory>

namespace objscan {

namespace {

struct Intrinsics {
  double fx, fy, cx, cy, skew;
};

template <typename T>
void PixelFromCamera(const Intrinsics& k, const T* pc, T* uv) {
  const T x = pc[0] / pc[2], y = pc[1] / pc[2];
  uv[0] = k.fx * x + k.skew * y + k.cx;
  uv[1] = k.fy * y + k.cy;
}

// camera_from_world for 6 parameters (angle-axis, translation).
template <typename T>
void CameraFromWorldSix(const T* cam, const T* pw, T* pc) {
  ceres::AngleAxisRotatePoint(cam, pw, pc);
  pc[0] += cam[3];
  pc[1] += cam[4];
  pc[2] += cam[5];
}

struct FourDofGeometry {
  double height, off_x, off_y, off_z;
};

template <typename T>
void TiltRotation(const T* cam, T r[3][3]) {
  using std::cos;
  using std::sin;
  const T c = cos(cam[2]), s = sin(cam[2]), ct = cos(cam[3]), st = sin(cam[3]);
  r[0][0] = c * ct, r[0][1] = -s, r[0][2] = c * st;
  r[1][0] = s * ct, r[1][1] = c, r[1][2] = s * st;
  r[2][0] = -st, r[2][1] = T(0), r[2][2] = ct;
}

template <typename T>
void CameraFromWorldFour(const FourDofGeometry& g, const T* cam, const T* pw, T* pc) {
  T r[3][3];
  TiltRotation(cam, r);
  const T d[3] = {pw[0] - cam[0], pw[1] - cam[1], pw[2] - T(g.height)};
  T pt[3];
  for (int i = 0; i < 3; ++i) pt[i] = r[0][i] * d[0] + r[1][i] * d[1] + r[2][i] * d[2];
  pc[0] = -(pt[1] - T(g.off_y));
  pc[1] = -(pt[2] - T(g.off_z));
  pc[2] = pt[0] - T(g.off_x);
}

template <typename T>
void CentreSix(const T* cam, T* c) {
  const T minus_aa[3] = {-cam[0], -cam[1], -cam[2]};
  const T t[3] = {cam[3], cam[4], cam[5]};
  ceres::AngleAxisRotatePoint(minus_aa, t, c);
  for (int i = 0; i < 3; ++i) c[i] = -c[i];
}

template <typename T>
void CentreFour(const FourDofGeometry& g, const T* cam, T* c) {
  T r[3][3];
  TiltRotation(cam, r);
  const T off[3] = {T(g.off_x), T(g.off_y), T(g.off_z)};
  const T o[3] = {cam[0], cam[1], T(g.height)};
  for (int i = 0; i < 3; ++i) c[i] = o[i] + r[i][0] * off[0] + r[i][1] * off[1] + r[i][2] * off[2];
}

// Residual (px) of a point in the camera frame against the measured pixel (u, v); a point behind the camera gets a
// large constant residual instead of a projection.
template <typename T>
bool PixelResidual(const Intrinsics& k, const T* pc, double u, double v, T* res) {
  if (pc[2] <= T(1e-6)) {
    res[0] = T(1e3);
    res[1] = T(1e3);
    return true;
  }
  T uv[2];
  PixelFromCamera(k, pc, uv);
  res[0] = uv[0] - u;
  res[1] = uv[1] - v;
  return true;
}

struct ReprojectionSix {
  Intrinsics k;
  double u, v;
  template <typename T>
  bool operator()(const T* cam, const T* pw, T* res) const {
    T pc[3];
    CameraFromWorldSix(cam, pw, pc);
    return PixelResidual(k, pc, u, v, res);
  }
};

struct ReprojectionFour {
  Intrinsics k;
  FourDofGeometry g;
  double u, v;
  template <typename T>
  bool operator()(const T* cam, const T* pw, T* res) const {
    T pc[3];
    CameraFromWorldFour(g, cam, pw, pc);
    return PixelResidual(k, pc, u, v, res);
  }
};

// Pose-only residual: the point is data.
template <bool kSix>
struct PoseOnlyReprojection {
  Intrinsics k;
  FourDofGeometry g;
  double x, y, z, u, v;
  template <typename T>
  bool operator()(const T* cam, T* res) const {
    const T pw[3] = {T(x), T(y), T(z)};
    T pc[3];
    if (kSix)
      CameraFromWorldSix(cam, pw, pc);
    else
      CameraFromWorldFour(g, cam, pw, pc);
    return PixelResidual(k, pc, u, v, res);
  }
};

struct DistancePrior {
  bool six;
  FourDofGeometry g;
  double distance, weight;
  template <typename T>
  bool operator()(const T* a, const T* b, T* res) const {
    T ca[3], cb[3];
    if (six) {
      CentreSix(a, ca);
      CentreSix(b, cb);
    } else {
      CentreFour(g, a, ca);
      CentreFour(g, b, cb);
    }
    const T d = ceres::sqrt((ca[0] - cb[0]) * (ca[0] - cb[0]) + (ca[1] - cb[1]) * (ca[1] - cb[1]) +
                            (ca[2] - cb[2]) * (ca[2] - cb[2]) + T(1e-12));
    res[0] = T(weight) * (d - T(distance));
    return true;
  }
};

Intrinsics MakeIntrinsics(const PinholeCamera& c) { return {c.fx, c.fy, c.cx, c.cy, c.skew}; }
FourDofGeometry MakeGeometry(const RobotGeometry& r) {
  return {r.mast_height_mm, r.camera_offset_mm.x(), r.camera_offset_mm.y(), r.camera_offset_mm.z()};
}

void ToSix(const Eigen::Isometry3d& world_from_camera, double* p) {
  const Eigen::Isometry3d cw = world_from_camera.inverse();
  const Eigen::AngleAxisd aa(cw.linear());
  const Eigen::Vector3d v = aa.angle() * aa.axis();
  p[0] = v.x(), p[1] = v.y(), p[2] = v.z();
  p[3] = cw.translation().x(), p[4] = cw.translation().y(), p[5] = cw.translation().z();
}

Eigen::Isometry3d FromSix(const double* p) {
  Eigen::Isometry3d cw = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d v(p[0], p[1], p[2]);
  const double angle = v.norm();
  if (angle > 1e-15) cw.linear() = Eigen::AngleAxisd(angle, v / angle).toRotationMatrix();
  cw.translation() = Eigen::Vector3d(p[3], p[4], p[5]);
  return cw.inverse();
}

}  // namespace

Eigen::Isometry3d WorldFromCameraFloor(const RobotGeometry& robot, const FloorPose& p) {
  Eigen::Isometry3d world_from_tilt = Eigen::Isometry3d::Identity();
  world_from_tilt.linear() =
      (Eigen::AngleAxisd(p.yaw_rad, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(p.tilt_rad, Eigen::Vector3d::UnitY()))
          .toRotationMatrix();
  world_from_tilt.translation() = Eigen::Vector3d(p.x_mm, p.y_mm, robot.mast_height_mm);
  Eigen::Isometry3d tilt_from_camera = Eigen::Isometry3d::Identity();
  tilt_from_camera.linear() = TiltFromCameraRotation();
  tilt_from_camera.translation() = robot.camera_offset_mm;
  return world_from_tilt * tilt_from_camera;
}

FloorPose FloorPoseFromWorldFromCamera(const RobotGeometry& robot, const Eigen::Isometry3d& world_from_camera) {
  const Eigen::Matrix3d r_wt = world_from_camera.linear() * TiltFromCameraRotation().transpose();
  FloorPose p;
  p.yaw_rad = std::atan2(r_wt(1, 0), r_wt(0, 0));
  p.tilt_rad = std::atan2(-r_wt(2, 0), std::hypot(r_wt(0, 0), r_wt(1, 0)));
  const Eigen::Matrix3d r_model =
      (Eigen::AngleAxisd(p.yaw_rad, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(p.tilt_rad, Eigen::Vector3d::UnitY()))
          .toRotationMatrix();
  const Eigen::Vector3d o = world_from_camera.translation() - r_model * robot.camera_offset_mm;
  p.x_mm = o.x();
  p.y_mm = o.y();
  return p;
}

bool ProjectIdeal(const PinholeCamera& c, const Eigen::Vector3d& pc, Eigen::Vector2d* pixel) {
  if (!(pc.z() > 1e-9)) return false;
  const double x = pc.x() / pc.z(), y = pc.y() / pc.z();
  *pixel = Eigen::Vector2d(c.fx * x + c.skew * y + c.cx, c.fy * y + c.cy);
  return true;
}

Eigen::Vector2d UndistortPixel(const PinholeCamera& c, const Eigen::Vector2d& pixel) {
  if (!c.HasDistortion()) return pixel;
  const Eigen::Vector2d n = c.Unproject(pixel);
  return Eigen::Vector2d(c.fx * n.x() + c.skew * n.y() + c.cx, c.fy * n.y() + c.cy);
}

double ReprojectionRms(const PinholeCamera& camera, const BaProblem& p) {
  double sum = 0;
  int n = 0;
  for (const auto& o : p.observations) {
    if (o.frame < 0 || o.frame >= static_cast<int>(p.world_from_camera.size()) || o.point < 0 ||
        o.point >= static_cast<int>(p.points.size()))
      continue;
    Eigen::Vector2d uv;
    const Eigen::Vector3d pc = p.world_from_camera[o.frame].inverse() * p.points[o.point];
    const double e = ProjectIdeal(camera, pc, &uv) ? (uv - o.pixel).squaredNorm() : 1e6;
    sum += e;
    ++n;
  }
  return n > 0 ? std::sqrt(sum / n) : 0.0;
}

BaSummary RunBundleAdjustment(const PinholeCamera& camera, const RobotGeometry& robot, const BaOptions& options,
                              BaProblem* p) {
  BaSummary summary;
  const int num_frames = static_cast<int>(p->world_from_camera.size());
  const int num_points = static_cast<int>(p->points.size());
  for (const auto& t : p->world_from_camera)
    if (!t.matrix().allFinite()) {
      summary.message = "non-finite pose";
      return summary;
    }
  for (const auto& x : p->points)
    if (!x.allFinite()) {
      summary.message = "non-finite point";
      return summary;
    }
  const bool six = options.model == MotionModel::kSixDof;
  const int cam_size = six ? 6 : 4;
  std::vector<double> cams(static_cast<size_t>(num_frames) * cam_size);
  for (int f = 0; f < num_frames; ++f) {
    double* c = &cams[static_cast<size_t>(f) * cam_size];
    if (six) {
      ToSix(p->world_from_camera[f], c);
    } else {
      const FloorPose fp = FloorPoseFromWorldFromCamera(robot, p->world_from_camera[f]);
      c[0] = fp.x_mm, c[1] = fp.y_mm, c[2] = fp.yaw_rad, c[3] = fp.tilt_rad;
    }
  }
  std::vector<double> pts(static_cast<size_t>(num_points) * 3);
  for (int i = 0; i < num_points; ++i) {
    const bool floor = i < static_cast<int>(p->point_on_floor.size()) && p->point_on_floor[i];
    pts[3 * i] = p->points[i].x();
    pts[3 * i + 1] = p->points[i].y();
    pts[3 * i + 2] = floor ? 0.0 : p->points[i].z();
  }
  summary.initial_rms_px = ReprojectionRms(camera, *p);

  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  std::unique_ptr<ceres::LossFunction> loss;
  if (options.loss == "huber")
    loss = std::make_unique<ceres::HuberLoss>(options.loss_scale_px);
  else if (options.loss == "cauchy")
    loss = std::make_unique<ceres::CauchyLoss>(options.loss_scale_px);
  const Intrinsics k = MakeIntrinsics(camera);
  const FourDofGeometry g = MakeGeometry(robot);
  // Points seen by fewer than two distinct frames carry no information (free, they only make the Schur complement
  // singular; fixed, they would pin the camera to their old estimate): their observations are left out and the
  // points returned unchanged. A fixed point (point_fixed) keeps even a single observation.
  std::vector<int> point_first_frame(num_points, -1);
  std::vector<uint8_t> point_multi(num_points, 0);
  for (const auto& o : p->observations) {
    if (o.frame < 0 || o.frame >= num_frames || o.point < 0 || o.point >= num_points) continue;
    if (point_first_frame[o.point] < 0)
      point_first_frame[o.point] = o.frame;
    else if (point_first_frame[o.point] != o.frame)
      point_multi[o.point] = 1;
  }
  for (int i = 0; i < num_points && i < static_cast<int>(p->point_fixed.size()); ++i)
    if (p->point_fixed[i]) point_multi[i] = 1;
  std::vector<uint8_t> frame_used(num_frames, 0), point_used(num_points, 0);
  for (const auto& o : p->observations) {
    if (o.frame < 0 || o.frame >= num_frames || o.point < 0 || o.point >= num_points) continue;
    if (!point_multi[o.point]) continue;
    double* c = &cams[static_cast<size_t>(o.frame) * cam_size];
    double* x = &pts[3 * static_cast<size_t>(o.point)];
    ceres::CostFunction* cost;
    if (six)
      cost =
          new ceres::AutoDiffCostFunction<ReprojectionSix, 2, 6, 3>(new ReprojectionSix{k, o.pixel.x(), o.pixel.y()});
    else
      cost = new ceres::AutoDiffCostFunction<ReprojectionFour, 2, 4, 3>(
          new ReprojectionFour{k, g, o.pixel.x(), o.pixel.y()});
    problem.AddResidualBlock(cost, loss.get(), c, x);
    frame_used[o.frame] = 1;
    point_used[o.point] = 1;
  }
  if (problem.NumResidualBlocks() == 0) {
    summary.message = "no observations";
    return summary;
  }
  const int a = p->distance_frame_a, b = p->distance_frame_b;
  if (a >= 0 && b >= 0 && a < num_frames && b < num_frames && a != b && frame_used[a] && frame_used[b]) {
    ceres::CostFunction* cost;
    if (six)
      cost = new ceres::AutoDiffCostFunction<DistancePrior, 1, 6, 6>(
          new DistancePrior{true, g, p->distance_mm, p->distance_weight});
    else
      cost = new ceres::AutoDiffCostFunction<DistancePrior, 1, 4, 4>(
          new DistancePrior{false, g, p->distance_mm, p->distance_weight});
    problem.AddResidualBlock(cost, nullptr, &cams[static_cast<size_t>(a) * cam_size],
                             &cams[static_cast<size_t>(b) * cam_size]);
  }
  int free_frames = 0;
  for (int f = 0; f < num_frames; ++f) {
    if (!frame_used[f]) continue;
    double* c = &cams[static_cast<size_t>(f) * cam_size];
    const FrameFix fix = f < static_cast<int>(p->frame_fix.size()) ? p->frame_fix[f] : FrameFix::kFree;
    if (fix == FrameFix::kFixed || (fix == FrameFix::kFixedFloor && six)) {
      problem.SetParameterBlockConstant(c);
    } else if (fix == FrameFix::kFixedFloor) {
      problem.SetManifold(c, new ceres::SubsetManifold(4, {0, 1, 2}));
      ++free_frames;
    } else {
      ++free_frames;
    }
  }
  for (int i = 0; i < num_points; ++i) {
    if (!point_used[i]) continue;
    double* x = &pts[3 * static_cast<size_t>(i)];
    if (i < static_cast<int>(p->point_fixed.size()) && p->point_fixed[i])
      problem.SetParameterBlockConstant(x);
    else if (i < static_cast<int>(p->point_on_floor.size()) && p->point_on_floor[i])
      problem.SetManifold(x, new ceres::SubsetManifold(3, {2}));
  }
  ceres::Solver::Options so;
  so.linear_solver_type = free_frames <= 40 ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
  so.max_num_iterations = options.max_iterations;
  so.function_tolerance = options.function_tolerance;
  so.num_threads = options.num_threads;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary s;
  ceres::Solve(so, &problem, &s);
  summary.iterations = static_cast<int>(s.iterations.size());
  summary.message = s.BriefReport();
  summary.converged = s.termination_type == ceres::CONVERGENCE;
  if (s.termination_type == ceres::FAILURE || !std::isfinite(s.final_cost)) return summary;
  for (int f = 0; f < num_frames; ++f) {
    if (!frame_used[f]) continue;
    const double* c = &cams[static_cast<size_t>(f) * cam_size];
    if (six)
      p->world_from_camera[f] = FromSix(c);
    else
      p->world_from_camera[f] = WorldFromCameraFloor(robot, {c[0], c[1], c[2], c[3]});
  }
  for (int i = 0; i < num_points; ++i)
    if (point_used[i]) p->points[i] = Eigen::Vector3d(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]);
  summary.final_rms_px = ReprojectionRms(camera, *p);
  summary.ok = true;
  return summary;
}

bool RefinePose(const PinholeCamera& camera, const RobotGeometry& robot, const BaOptions& options,
                const std::vector<Eigen::Vector3d>& points_in_world, const std::vector<Eigen::Vector2d>& pixels,
                const std::vector<int>& use, Eigen::Isometry3d* world_from_camera) {
  if (!world_from_camera->matrix().allFinite() || use.empty()) return false;
  const bool six = options.model == MotionModel::kSixDof;
  double cam[6];
  if (six) {
    ToSix(*world_from_camera, cam);
  } else {
    const FloorPose fp = FloorPoseFromWorldFromCamera(robot, *world_from_camera);
    cam[0] = fp.x_mm, cam[1] = fp.y_mm, cam[2] = fp.yaw_rad, cam[3] = fp.tilt_rad;
  }
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  std::unique_ptr<ceres::LossFunction> loss;
  if (options.loss == "huber")
    loss = std::make_unique<ceres::HuberLoss>(options.loss_scale_px);
  else if (options.loss == "cauchy")
    loss = std::make_unique<ceres::CauchyLoss>(options.loss_scale_px);
  const Intrinsics k = MakeIntrinsics(camera);
  const FourDofGeometry g = MakeGeometry(robot);
  for (int i : use) {
    if (i < 0 || i >= static_cast<int>(points_in_world.size()) || i >= static_cast<int>(pixels.size())) continue;
    const Eigen::Vector3d& x = points_in_world[i];
    if (!x.allFinite()) continue;
    ceres::CostFunction* cost;
    if (six)
      cost = new ceres::AutoDiffCostFunction<PoseOnlyReprojection<true>, 2, 6>(
          new PoseOnlyReprojection<true>{k, g, x.x(), x.y(), x.z(), pixels[i].x(), pixels[i].y()});
    else
      cost = new ceres::AutoDiffCostFunction<PoseOnlyReprojection<false>, 2, 4>(
          new PoseOnlyReprojection<false>{k, g, x.x(), x.y(), x.z(), pixels[i].x(), pixels[i].y()});
    problem.AddResidualBlock(cost, loss.get(), cam);
  }
  if (problem.NumResidualBlocks() == 0) return false;
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = options.max_iterations;
  so.function_tolerance = options.function_tolerance;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary s;
  ceres::Solve(so, &problem, &s);
  if (s.termination_type == ceres::FAILURE || !std::isfinite(s.final_cost)) return false;
  *world_from_camera = six ? FromSix(cam) : WorldFromCameraFloor(robot, {cam[0], cam[1], cam[2], cam[3]});
  return world_from_camera->matrix().allFinite();
}

}  // namespace objscan
