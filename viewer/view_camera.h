// The viewer's 3-D view camera: an orbit camera (target, yaw, pitch, distance) with an OpenGL perspective projection,
// plus the mapping from world points to window pixels. The renderer and the tests use these same functions, so a
// test can compute where a known world point must appear in a screenshot.
// Frames: world z up, lengths in mm, angles in rad. Window pixels (u, v) = (column, row) with the origin at the
// centre of the top-left pixel of the window (framebuffer), as everywhere in objscan.
#pragma once

#include <Eigen/Core>
#include <string>

namespace objscan {

struct OrbitView {
  Eigen::Vector3d target_mm{0.0, 0.0, 0.0};  // mm, point the camera looks at (world)
  double yaw_rad = -2.2;                     // rad, azimuth of the eye about world +z, from +x (eye = target + d * dir)
  double pitch_rad = 0.6;       // rad, elevation of the eye above the target's horizontal plane (-1.55..1.55)
  double distance_mm = 3000.0;  // mm, eye to target (> 0)
  double fovy_rad = 0.8726646;  // rad, vertical field of view (50 deg)
  double near_mm = 10.0;        // mm, near clipping plane
  double far_mm = 200000.0;     // mm, far clipping plane
};

// A rectangle of the window in pixels, top-left origin (x = column of the left edge, y = row of the top edge).
struct Viewport {
  int x = 0;
  int y = 0;
  int width = 1;
  int height = 1;
};

// Eye position in world (mm).
Eigen::Vector3d EyePosition(const OrbitView& view);
// OpenGL view matrix (eye_from_world; eye x right, y up, looking down -z), world z is "up" on screen.
Eigen::Matrix4f ViewMatrix(const OrbitView& view);
// OpenGL perspective projection for the viewport aspect ratio width / height.
Eigen::Matrix4f ProjectionMatrix(const OrbitView& view, double aspect);
// Window pixel of a world point as drawn in viewport; false when the point is behind the eye or outside the
// clipping volume.
bool ProjectToWindow(const OrbitView& view, const Viewport& viewport, const Eigen::Vector3d& point_in_world,
                     Eigen::Vector2d* pixel);

// Named presets: "iso" (default orbit), "top" (looking straight down), "front" (from -y), "side" (from +x).
// Sets the angles only (target and distance unchanged). False for an unknown name.
bool ApplyViewPreset(const std::string& name, OrbitView* view);

// The viewer's --view option: PRESET or YAW,PITCH (deg), then optionally DISTANCE (mm), then X,Y,Z (the view
// target in world, mm), then FOV (vertical field of view, deg): "iso", "top,800", "-90,70", "0,25,600,10,0,80,40".
// A preset sets yaw and pitch as ApplyViewPreset does; omitted values are OrbitView's defaults (distance 3000 mm,
// target 0,0,0, fov 50 deg). Pitch is clamped to +-88.8 deg as the mouse does. Returns false with *why set for a
// bad spec: unknown preset, a value that is no finite number, a wrong count, distance <= 0, fov outside 1..170 deg.
bool ParseViewSpec(const std::string& spec, OrbitView* view, std::string* why);

// Mouse interaction (dx, dy in window pixels): orbit turns yaw/pitch, pan moves the target in the view plane,
// zoom scales the distance by exp(-steps * 0.1).
void OrbitBy(OrbitView* view, double dx_px, double dy_px);
void PanBy(OrbitView* view, const Viewport& viewport, double dx_px, double dy_px);
void ZoomBy(OrbitView* view, double steps);

}  // namespace objscan
