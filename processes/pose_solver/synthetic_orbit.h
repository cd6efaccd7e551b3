// Test/benchmark helper (header-only): a synthetic robot orbit around a textured sphere on a textured floor, with
// known truth. Points: sphere (radius sphere_radius_mm, centre (0, 0, radius)) and floor annulus; cameras from
// common/robot_model.h WorldFromCamera along a circle looking at the sphere centre; projections with Gaussian noise;
// tracks get a new id whenever a point (re)appears or a random dropout breaks it (KLT-like ids never reappear).
// Odometry = the true robot motion in the odometry frame (robot start pose) with a scale error, heading drift and
// pan/tilt biases. Deterministic for a seed.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <unordered_map>
#include <vector>

#include "common/camera_model.h"
#include "common/robot_model.h"
#include "common/sensor_data.h"

namespace objscan {

struct SyntheticOrbitOptions {
  int num_frames = 200;
  double orbit_radius_mm = 800;
  double orbit_fraction = 1.0;  // fraction of a full circle covered
  double sphere_radius_mm = 100;
  int num_sphere_points = 450;
  int num_floor_points = 350;
  double floor_min_radius_mm = 130, floor_max_radius_mm = 450;
  double noise_px = 0.3;
  double dropout_per_frame = 0.005;   // probability that a track breaks (new id) per frame
  double outlier_fraction = 0.0;      // observations displaced by 5..20 px
  double odometry_scale_error = 0.0;  // e.g. 0.02 = odometry distances 2 % too long
  double odometry_heading_drift_rad_per_frame = 0.0;
  double pan_bias_rad = 0.0, tilt_bias_rad = 0.0;
  int lost_begin = -1, lost_end = -1;  // frames [begin, end) see no features (tracking loss test)
  int floor_hidden_begin = -1, floor_hidden_end = -1;  // frames [begin, end) see no floor point
  // Before the orbit, the robot turns in place at its start for this many frames, through turn_in_place_rad (ending
  // at the orbit's start heading): a span of pure rotation (the camera's 40 mm offset aside).
  int turn_in_place_frames = 0;
  double turn_in_place_rad = 0.35;
  unsigned seed = 7;
};

struct SyntheticOrbit {
  PinholeCamera camera;
  RobotGeometry robot;
  std::vector<Eigen::Vector3d> points;               // truth, world
  std::vector<Eigen::Isometry3d> world_from_camera;  // truth per frame
  std::vector<TrackFrame> frames;
  std::vector<OdometryReading> odometry;            // one per frame, at the frame time
  std::unordered_map<int64_t, int> point_of_track;  // track id -> index into points (truth)
};

inline SyntheticOrbit MakeSyntheticOrbit(const SyntheticOrbitOptions& o) {
  SyntheticOrbit s;
  s.camera.name = "sim";
  s.camera.width = 640;
  s.camera.height = 480;
  s.camera.fx = s.camera.fy = 800;
  s.camera.cx = 319.5;
  s.camera.cy = 239.5;
  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<double> uni(0, 1);
  std::normal_distribution<double> gauss(0, 1);
  const Eigen::Vector3d centre(0, 0, o.sphere_radius_mm);
  for (int i = 0; i < o.num_sphere_points; ++i) {
    Eigen::Vector3d d(gauss(rng), gauss(rng), gauss(rng));
    s.points.push_back(centre + o.sphere_radius_mm * d.normalized());
  }
  for (int i = 0; i < o.num_floor_points; ++i) {
    const double r = std::sqrt(
        o.floor_min_radius_mm * o.floor_min_radius_mm +
        uni(rng) * (o.floor_max_radius_mm * o.floor_max_radius_mm - o.floor_min_radius_mm * o.floor_min_radius_mm));
    const double a = 2 * M_PI * uni(rng);
    s.points.push_back(Eigen::Vector3d(r * std::cos(a), r * std::sin(a), 0));
  }
  const int np = static_cast<int>(s.points.size());
  std::vector<int64_t> track_id(np, -1);
  int64_t next_id = 1;
  // Robot pose along the circle, counter-clockwise, heading tangent, pan +90 deg (looking at the centre).
  const Eigen::Vector3d camera_in_base_approx(0, 0, s.robot.mast_height_mm);
  const double start_angle = -M_PI / 2;  // robot starts at (0, -R) heading +x
  Eigen::Isometry3d world_from_odom = Eigen::Isometry3d::Identity();
  double odo_x = 0, odo_y = 0, odo_theta = 0;
  Eigen::Vector3d last_base(0, 0, 0);
  double last_theta = 0;
  const int num_turn = std::max(0, o.turn_in_place_frames);
  for (int f = 0; f < num_turn + o.num_frames; ++f) {
    const int orbit_frame = std::max(0, f - num_turn);
    const double a = start_angle + 2 * M_PI * o.orbit_fraction * orbit_frame / o.num_frames;
    const double x = o.orbit_radius_mm * std::cos(a), y = o.orbit_radius_mm * std::sin(a);
    const double turn_left = f < num_turn ? o.turn_in_place_rad * (1.0 - static_cast<double>(f) / num_turn) : 0.0;
    const double theta = a + M_PI / 2 - turn_left;
    const double pan = M_PI / 2;
    const double tilt = std::atan2(s.robot.mast_height_mm - o.sphere_radius_mm, o.orbit_radius_mm);
    const Eigen::Isometry3d wc = WorldFromCamera(s.robot, x, y, theta, pan, tilt);
    s.world_from_camera.push_back(wc);
    // Odometry.
    if (f == 0) {
      world_from_odom = WorldFromBase(x, y, theta);
    } else {
      const Eigen::Vector3d step_world(x - last_base.x(), y - last_base.y(), 0);
      const double dtheta = std::remainder(theta - last_theta, 2 * M_PI);
      const Eigen::Vector3d step_base =
          Eigen::AngleAxisd(-last_theta, Eigen::Vector3d::UnitZ()).toRotationMatrix() * step_world;
      const Eigen::Vector3d step_odo = Eigen::AngleAxisd(odo_theta, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                                       step_base * (1.0 + o.odometry_scale_error);
      odo_x += step_odo.x();
      odo_y += step_odo.y();
      odo_theta += dtheta + o.odometry_heading_drift_rad_per_frame;
    }
    last_base = Eigen::Vector3d(x, y, 0);
    last_theta = theta;
    OdometryReading r;
    r.utime = std::llround(f * 1e6 / 30.0);
    r.seq = f;
    r.x_mm = odo_x;
    r.y_mm = odo_y;
    r.theta_rad = odo_theta;
    r.pan_rad = pan + o.pan_bias_rad;
    r.tilt_rad = tilt + o.tilt_bias_rad;
    s.odometry.push_back(r);
    // Projections.
    TrackFrame tf;
    tf.utime = r.utime;
    tf.seq = f;
    tf.camera_name = "sim";
    tf.width = 640;
    tf.height = 480;
    const Eigen::Isometry3d cw = wc.inverse();
    const Eigen::Vector3d c = wc.translation();
    const bool blind = f >= o.lost_begin && f < o.lost_end;
    for (int i = 0; i < np; ++i) {
      bool visible = !blind;
      const Eigen::Vector3d& p = s.points[i];
      if (visible && i < o.num_sphere_points)
        visible = (p - centre).dot(c - p) > 0.05 * (c - p).norm() * o.sphere_radius_mm;
      if (visible && i >= o.num_sphere_points && f >= o.floor_hidden_begin && f < o.floor_hidden_end) visible = false;
      if (visible && i >= o.num_sphere_points) {  // floor point hidden behind the sphere?
        const Eigen::Vector3d d = (p - c).normalized();
        const double b = d.dot(c - centre);
        const double disc = b * b - ((c - centre).squaredNorm() - o.sphere_radius_mm * o.sphere_radius_mm);
        if (disc > 0 && -b - std::sqrt(disc) < (p - c).norm()) visible = false;
      }
      Eigen::Vector2d uv;
      if (visible) visible = s.camera.Project(cw * p, &uv) && s.camera.InImage(uv, 10);
      if (!visible) {
        track_id[i] = -1;
        continue;
      }
      if (track_id[i] < 0 || uni(rng) < o.dropout_per_frame) {
        track_id[i] = next_id++;
        s.point_of_track[track_id[i]] = i;
      }
      uv += o.noise_px * Eigen::Vector2d(gauss(rng), gauss(rng));
      if (uni(rng) < o.outlier_fraction) {
        const double m = 5 + 15 * uni(rng), ang = 2 * M_PI * uni(rng);
        uv += m * Eigen::Vector2d(std::cos(ang), std::sin(ang));
      }
      TrackedFeature t;
      t.id = track_id[i];
      t.u = static_cast<float>(uv.x());
      t.v = static_cast<float>(uv.y());
      tf.features.push_back(t);
    }
    s.frames.push_back(tf);
  }
  (void)camera_in_base_approx;
  (void)world_from_odom;
  return s;
}

}  // namespace objscan
