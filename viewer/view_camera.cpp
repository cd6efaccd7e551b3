#include "viewer/view_camera.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

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
