// Test helper (header-only, tests and benchmarks only): a textured sphere seen by pinhole cameras on a ring,
// rendered by a simple ray-caster, with synthetic feature tracks (exact projections of fixed surface points).
// Units mm; world z up; sphere r = 100 mm centred at (0, 0, 100) by default, cameras 640x480, f = 800 px.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <opencv2/core.hpp>
#include <vector>

#include "common/camera_model.h"
#include "common/sensor_data.h"
#include "processes/dense_modeler/region_of_interest.h"

namespace objscan {
namespace testing_scene {

inline PinholeCamera DefaultCamera() {
  PinholeCamera c;
  c.name = "sim";
  c.width = 640;
  c.height = 480;
  c.fx = c.fy = 800;
  c.cx = 319.5;
  c.cy = 239.5;
  return c;
}

// Camera at `eye` looking at `target`, image x right, y down (world z up).
inline Eigen::Isometry3d LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  const Eigen::Vector3d f = (target - eye).normalized();
  Eigen::Vector3d r = f.cross(Eigen::Vector3d::UnitZ());
  if (r.norm() < 1e-9) r = Eigen::Vector3d::UnitX();
  r.normalize();
  const Eigen::Vector3d d = f.cross(r);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear().col(0) = r;
  pose.linear().col(1) = d;
  pose.linear().col(2) = f;
  pose.translation() = eye;
  return pose;
}

// Smooth colour texture as a function of a world point (BGR, 0..255).
// A valid region: the box [box_min, box_max] (world, mm) cut by the floor z = floor_z_mm (normal +z) with this
// clearance (mm).
inline RegionOfInterest FloorRegion(const Eigen::Vector3d& box_min, const Eigen::Vector3d& box_max,
                                    double clearance_mm = 4, double floor_z_mm = 0) {
  RegionOfInterest r;
  r.valid = true;
  r.box_min = box_min;
  r.box_max = box_max;
  r.has_floor = true;
  r.floor.normal = Eigen::Vector3d::UnitZ();
  r.floor.offset_mm = -floor_z_mm;  // Height(x) = z - floor_z_mm
  r.floor_clearance_mm = clearance_mm;
  return r;
}

inline std::array<uint8_t, 3> Texture(const Eigen::Vector3d& p) {
  std::array<uint8_t, 3> out;
  const double k1 = 2 * M_PI / 23.0, k2 = 2 * M_PI / 13.0, k3 = 2 * M_PI / 37.0;
  for (int c = 0; c < 3; ++c) {
    const double v = 128 + 50 * std::sin(k1 * (p.x() * (1 + 0.3 * c) + 0.7 * p.y()) + c) +
                     35 * std::sin(k2 * (0.8 * p.y() - 0.6 * p.z() * (1 - 0.2 * c)) + 2 * c) +
                     30 * std::sin(k3 * (p.z() + 0.5 * p.x() - 0.3 * c * p.y()));
    out[c] = static_cast<uint8_t>(std::clamp(std::lround(v), 0L, 255L));
  }
  return out;
}

struct SphereScene {
  Eigen::Vector3d center{0, 0, 100};  // mm
  double radius = 100;                // mm
  PinholeCamera camera = DefaultCamera();
  cv::Vec3b background{40, 40, 40};

  Eigen::Isometry3d RingPose(int i, int n, double ring_radius = 800, double height = 400) const {
    const double a = 2 * M_PI * i / n;
    return LookAt(Eigen::Vector3d(ring_radius * std::cos(a), ring_radius * std::sin(a), height), center);
  }

  // Ray-cast image (BGR).
  cv::Mat Render(const Eigen::Isometry3d& world_from_camera) const {
    cv::Mat img(camera.height, camera.width, CV_8UC3, cv::Scalar(background[0], background[1], background[2]));
    const Eigen::Vector3d o = world_from_camera.translation();
    const Eigen::Matrix3d r = world_from_camera.linear();
    const Eigen::Vector3d oc = o - center;
    const double c = oc.squaredNorm() - radius * radius;
    for (int v = 0; v < camera.height; ++v) {
      cv::Vec3b* row = img.ptr<cv::Vec3b>(v);
      for (int u = 0; u < camera.width; ++u) {
        const Eigen::Vector3d d = (r * camera.Unproject(Eigen::Vector2d(u, v)).homogeneous()).normalized();
        const double b = oc.dot(d);
        const double disc = b * b - c;
        if (disc < 0) continue;
        const double s = -b - std::sqrt(disc);
        if (s <= 0) continue;
        const std::array<uint8_t, 3> t = Texture(o + s * d);
        row[u] = cv::Vec3b(t[0], t[1], t[2]);
      }
    }
    return img;
  }

  // n points spread evenly over the sphere (Fibonacci lattice).
  std::vector<Eigen::Vector3d> SurfacePoints(int n) const {
    std::vector<Eigen::Vector3d> pts;
    const double golden = M_PI * (3 - std::sqrt(5.0));
    for (int i = 0; i < n; ++i) {
      const double z = 1 - 2 * (i + 0.5) / n;
      const double rr = std::sqrt(1 - z * z);
      pts.push_back(center + radius * Eigen::Vector3d(rr * std::cos(golden * i), rr * std::sin(golden * i), z));
    }
    return pts;
  }

  // True when surface point p is in front of (facing) the camera and projects inside the image.
  bool Sees(const Eigen::Isometry3d& world_from_camera, const Eigen::Vector3d& p, Eigen::Vector2d* px,
            double min_cos = 0.05) const {
    const Eigen::Vector3d n = (p - center).normalized();
    const Eigen::Vector3d to_cam = world_from_camera.translation() - p;
    if (n.dot(to_cam.normalized()) < min_cos) return false;
    return camera.Project(world_from_camera.inverse() * p, px) && camera.InImage(*px, 2);
  }

  // Tracks: projections of the given surface points (id = index) visible in this view.
  TrackFrame Tracks(const Eigen::Isometry3d& world_from_camera, const std::vector<Eigen::Vector3d>& points,
                    int64_t seq) const {
    TrackFrame tf;
    tf.seq = seq;
    tf.utime = static_cast<int64_t>(std::llround(seq * 1e6 / 30.0));
    tf.camera_name = camera.name;
    tf.width = camera.width;
    tf.height = camera.height;
    for (size_t i = 0; i < points.size(); ++i) {
      Eigen::Vector2d px;
      if (!Sees(world_from_camera, points[i], &px, 0.15)) continue;
      TrackedFeature f;
      f.id = static_cast<int64_t>(i);
      f.u = static_cast<float>(px.x());
      f.v = static_cast<float>(px.y());
      tf.features.push_back(f);
    }
    return tf;
  }
};

}  // namespace testing_scene
}  // namespace objscan
