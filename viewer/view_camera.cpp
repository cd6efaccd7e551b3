#include "viewer/view_camera.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <vector>

#include "common/options.h"

namespace objscan {
namespace {
constexpr double kMaxPitch = 1.55;

Eigen::Vector3d ViewDirection(const OrbitView& view) {  // unit vector target -> eye
  return {std::cos(view.pitch_rad) * std::cos(view.yaw_rad), std::cos(view.pitch_rad) * std::sin(view.yaw_rad),
          std::sin(view.pitch_rad)};
}

// Right and up axes of the eye in world.
void EyeAxes(const OrbitView& view, Eigen::Vector3d* right, Eigen::Vector3d* up, Eigen::Vector3d* back) {
  *back = ViewDirection(view);
  // Horizontal right vector from the yaw alone keeps the basis stable when looking straight down.
  *right = Eigen::Vector3d(-std::sin(view.yaw_rad), std::cos(view.yaw_rad), 0.0);
  *up = back->cross(*right).normalized();
  *right = up->cross(*back).normalized();
}
}  // namespace

Eigen::Vector3d EyePosition(const OrbitView& view) { return view.target_mm + view.distance_mm * ViewDirection(view); }

Eigen::Matrix4f ViewMatrix(const OrbitView& view) {
  Eigen::Vector3d right, up, back;
  EyeAxes(view, &right, &up, &back);
  const Eigen::Vector3d eye = EyePosition(view);
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.block<1, 3>(0, 0) = right.transpose();
  m.block<1, 3>(1, 0) = up.transpose();
  m.block<1, 3>(2, 0) = back.transpose();
  m(0, 3) = -right.dot(eye);
  m(1, 3) = -up.dot(eye);
  m(2, 3) = -back.dot(eye);
  return m.cast<float>();
}

Eigen::Matrix4f ProjectionMatrix(const OrbitView& view, double aspect) {
  const double f = 1.0 / std::tan(view.fovy_rad / 2.0);
  const double n = view.near_mm, fa = view.far_mm;
  Eigen::Matrix4d p = Eigen::Matrix4d::Zero();
  p(0, 0) = f / std::max(aspect, 1e-6);
  p(1, 1) = f;
  p(2, 2) = (fa + n) / (n - fa);
  p(2, 3) = 2.0 * fa * n / (n - fa);
  p(3, 2) = -1.0;
  return p.cast<float>();
}

bool ProjectToWindow(const OrbitView& view, const Viewport& viewport, const Eigen::Vector3d& point_in_world,
                     Eigen::Vector2d* pixel) {
  const Eigen::Matrix4d mvp =
      (ProjectionMatrix(view, static_cast<double>(viewport.width) / viewport.height) * ViewMatrix(view)).cast<double>();
  const Eigen::Vector4d clip = mvp * point_in_world.homogeneous();
  if (clip.w() <= 0) return false;
  const Eigen::Vector3d ndc = clip.head<3>() / clip.w();
  if (ndc.cwiseAbs().maxCoeff() > 1.0) return false;
  // Window coordinates have the pixel edge at 0; objscan pixels have the centre of the first pixel at 0.
  pixel->x() = viewport.x + (ndc.x() + 1.0) * 0.5 * viewport.width - 0.5;
  pixel->y() = viewport.y + (1.0 - ndc.y()) * 0.5 * viewport.height - 0.5;
  return true;
}

bool ApplyViewPreset(const std::string& name, OrbitView* view) {
  if (name == "iso") {
    view->yaw_rad = -2.2;
    view->pitch_rad = 0.6;
  } else if (name == "top") {
    view->yaw_rad = -M_PI / 2;
    view->pitch_rad = kMaxPitch;
  } else if (name == "front") {
    view->yaw_rad = -M_PI / 2;
    view->pitch_rad = 0.15;
  } else if (name == "side") {
    view->yaw_rad = 0.0;
    view->pitch_rad = 0.15;
  } else {
    return false;
  }
  return true;
}

bool ParseViewSpec(const std::string& spec, OrbitView* view, std::string* why) {
  auto fail = [&](const std::string& reason) {
    if (why) *why = "--view '" + spec + "': " + reason;
    return false;
  };
  std::vector<std::string> fields;
  for (size_t start = 0;;) {
    const size_t comma = spec.find(',', start);
    fields.push_back(spec.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  constexpr const char* kForm = "want PRESET (iso, top, front, side) or YAW,PITCH (deg), then optionally ,DISTANCE "
                                "(mm), then ,X,Y,Z (target, mm), then ,FOV (deg)";
  OrbitView v;
  size_t next = 0;  // first field after the angles
  if (ApplyViewPreset(fields[0], &v)) {
    next = 1;
  } else {
    double yaw = 0, pitch = 0;
    if (fields.size() < 2) return fail(fields[0].empty() ? kForm : "unknown preset '" + fields[0] + "'; " + kForm);
    if (!ParseFiniteNumber(fields[0], &yaw)) return fail("yaw '" + fields[0] + "' is no finite number; " + kForm);
    if (!ParseFiniteNumber(fields[1], &pitch)) return fail("pitch '" + fields[1] + "' is no finite number");
    v.yaw_rad = yaw * (M_PI / 180);
    v.pitch_rad = std::clamp(pitch * (M_PI / 180), -kMaxPitch, kMaxPitch);
    next = 2;
  }
  const size_t extra = fields.size() - next;  // 0, 1 (distance), 4 (+ target) or 5 (+ fov)
  if (extra != 0 && extra != 1 && extra != 4 && extra != 5)
    return fail(std::to_string(fields.size()) + " values; " + kForm);
  double values[5] = {v.distance_mm, v.target_mm.x(), v.target_mm.y(), v.target_mm.z(), 50.0};
  const char* names[5] = {"distance", "target x", "target y", "target z", "fov"};
  for (size_t i = 0; i < extra; ++i)
    if (!ParseFiniteNumber(fields[next + i], &values[i]))
      return fail(std::string(names[i]) + " '" + fields[next + i] + "' is no finite number");
  if (!(values[0] > 0)) return fail("distance must be > 0 mm");
  if (!(values[4] >= 1 && values[4] <= 170)) return fail("fov must be in 1..170 deg");
  v.distance_mm = values[0];
  v.target_mm = Eigen::Vector3d(values[1], values[2], values[3]);
  v.fovy_rad = values[4] * (M_PI / 180);
  *view = v;
  return true;
}

void OrbitBy(OrbitView* view, double dx_px, double dy_px) {
  view->yaw_rad -= dx_px * 0.006;
  view->pitch_rad = std::clamp(view->pitch_rad + dy_px * 0.006, -kMaxPitch, kMaxPitch);
}

void PanBy(OrbitView* view, const Viewport& viewport, double dx_px, double dy_px) {
  Eigen::Vector3d right, up, back;
  EyeAxes(*view, &right, &up, &back);
  const double mm_per_px = 2.0 * view->distance_mm * std::tan(view->fovy_rad / 2) / std::max(viewport.height, 1);
  view->target_mm += (-dx_px * right + dy_px * up) * mm_per_px;
}

void ZoomBy(OrbitView* view, double steps) {
  view->distance_mm = std::clamp(view->distance_mm * std::exp(-steps * 0.1), 50.0, 1e6);
}

}  // namespace objscan
