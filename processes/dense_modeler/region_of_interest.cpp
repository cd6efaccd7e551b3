#include "processes/dense_modeler/region_of_interest.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "common/geometry.h"
#include "common/options.h"

namespace objscan {
namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  return v[mid];
}

}  // namespace

double RegionOfInterest::HeightAboveFloor(const Eigen::Vector3d& x) const {
  if (!has_floor) return std::numeric_limits<double>::infinity();
  return floor.Height(x);
}

bool RegionOfInterest::Contains(const Eigen::Vector3d& x) const {
  if (!valid) return true;
  if (!((x.array() >= box_min.array()).all() && (x.array() <= box_max.array()).all())) return false;
  return !has_floor || HeightAboveFloor(x) >= floor_clearance_mm;
}

bool RegionOfInterest::TriangleOutside(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& p2,
                                       double slack) const {
  if (!valid) return false;
  for (int k = 0; k < 3; ++k) {
    if (p0[k] < box_min[k] - slack && p1[k] < box_min[k] - slack && p2[k] < box_min[k] - slack) return true;
    if (p0[k] > box_max[k] + slack && p1[k] > box_max[k] + slack && p2[k] > box_max[k] + slack) return true;
  }
  if (has_floor) {
    const double limit = floor_clearance_mm - slack;
    if (HeightAboveFloor(p0) < limit && HeightAboveFloor(p1) < limit && HeightAboveFloor(p2) < limit) return true;
  }
  return false;
}

bool RegionOfInterest::TriangleOnFloor(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                                       const Eigen::Vector3d& p2) const {
  if (!valid || !has_floor || !(floor_clearance_mm > 0)) return false;
  const double on_floor = 0.5 * floor_clearance_mm;
  return HeightAboveFloor(p0) < on_floor && HeightAboveFloor(p1) < on_floor && HeightAboveFloor(p2) < on_floor;
}

bool RegionOfInterest::TriangleSpansFloorJunction(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                                                  const Eigen::Vector3d& p2) const {
  if (!has_floor) return false;
  const double h0 = HeightAboveFloor(p0), h1 = HeightAboveFloor(p1), h2 = HeightAboveFloor(p2);
  return std::min({h0, h1, h2}) < 0.5 * floor_clearance_mm && std::max({h0, h1, h2}) > floor_clearance_mm;
}

cv::Rect RegionOfInterest::ImageRect(const PinholeCamera& camera, const Eigen::Isometry3d& world_from_camera,
                                     double margin_px) const {
  const cv::Rect whole(0, 0, camera.width, camera.height);
  if (!valid) return whole;
  const Eigen::Isometry3d camera_from_world = world_from_camera.inverse();
  double u_lo = std::numeric_limits<double>::infinity(), v_lo = u_lo, u_hi = -u_lo, v_hi = -u_lo;
  int behind = 0;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d corner((c & 1) ? box_max.x() : box_min.x(), (c & 2) ? box_max.y() : box_min.y(),
                                 (c & 4) ? box_max.z() : box_min.z());
    const Eigen::Vector3d pc = camera_from_world * corner;
    Eigen::Vector2d uv;
    if (pc.z() <= 1e-6 || !camera.Project(pc, &uv)) {
      ++behind;
      continue;
    }
    u_lo = std::min(u_lo, uv.x()), u_hi = std::max(u_hi, uv.x());
    v_lo = std::min(v_lo, uv.y()), v_hi = std::max(v_hi, uv.y());
  }
  if (behind == 8) return cv::Rect();
  if (behind > 0) return whole;
  const int x0 = static_cast<int>(std::floor(std::max(u_lo - margin_px, -1.0)));
  const int y0 = static_cast<int>(std::floor(std::max(v_lo - margin_px, -1.0)));
  const int x1 = static_cast<int>(std::ceil(std::min(u_hi + margin_px, camera.width + 1.0)));
  const int y1 = static_cast<int>(std::ceil(std::min(v_hi + margin_px, camera.height + 1.0)));
  if (x1 <= x0 || y1 <= y0) return cv::Rect();
  return cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1) & whole;
}

bool ValidateAutoRoiOptions(const AutoRoiOptions& o, std::string* why) {
  std::ostringstream e;
  if (!(o.central_fraction > 0 && o.central_fraction <= 1)) e << "roi central_fraction must be in (0, 1]; ";
  if (o.min_central_views < 1) e << "roi min_central_views must be >= 1; ";
  if (o.min_central_landmarks < 3) e << "roi min_central_landmarks must be >= 3; ";
  if (!(o.cluster_k > 0)) e << "roi cluster_k must be > 0; ";
  if (!(o.margin_mm >= 0) || !(o.margin_fraction >= 0)) e << "roi margin_mm and margin_fraction must be >= 0; ";
  if (!(o.floor_radius_mm > 0)) e << "roi floor_radius_mm must be > 0; ";
  if (!(o.floor_tolerance_mm > 0)) e << "roi floor_tolerance_mm must be > 0; ";
  if (o.min_floor_points < 3) e << "roi min_floor_points must be >= 3; ";
  if (!(o.max_floor_tilt_deg > 0 && o.max_floor_tilt_deg < 90)) e << "roi max_floor_tilt_deg must be in (0, 90); ";
  if (!(o.floor_clearance_mm >= 0)) e << "roi-floor-clearance must be >= 0; ";
  if (o.ransac_iterations < 1) e << "roi ransac_iterations must be >= 1; ";
  const std::string msg = e.str();
  if (msg.empty()) return true;
  if (why) *why = msg.substr(0, msg.size() - 2);
  return false;
}

void CountCentralTracks(const PinholeCamera& camera, const std::vector<std::pair<int64_t, Eigen::Vector2d>>& tracks,
                        double central_fraction, std::unordered_map<int64_t, int>* counts) {
  const double half_w = 0.5 * central_fraction * camera.width, half_h = 0.5 * central_fraction * camera.height;
  for (const auto& [id, uv] : tracks)
    if (std::abs(uv.x() - camera.cx) <= half_w && std::abs(uv.y() - camera.cy) <= half_h) ++(*counts)[id];
}

bool FitFloorPlane(const std::vector<Eigen::Vector3d>& points, double tolerance, double max_tilt_deg, int min_points,
                   int iterations, PlaneSupport* floor) {
  if (static_cast<int>(points.size()) < std::max(3, min_points)) return false;
  PlaneSampling sampling;
  sampling.max_tilt_deg = max_tilt_deg;
  sampling.iterations = iterations;
  sampling.sequence = SampleIndexSequence::kLcg;
  sampling.seed = 0x5eed0f100dULL;
  PlaneSupport best = MostSupportedPlane(points, sampling, tolerance);
  if (best.inliers < min_points) return false;
  // Least-squares refit to the inliers (twice: the inlier set can change a little); a refit tilted too far is not
  // taken.
  for (int pass = 0; pass < 2; ++pass) {
    FloorPlane refit = best.plane;
    if (!RefitPlaneToInliers(points, tolerance, sampling.up, &refit) ||
        !NormalWithinTilt(refit, sampling.up, max_tilt_deg))
      break;
    best.plane = refit;
  }
  best.inliers = CountPlaneInliers(points, best.plane, tolerance);
  if (best.inliers < min_points) return false;
  *floor = best;
  return true;
}

int AddFloorNear(const std::vector<Eigen::Vector3d>& landmarks, const Eigen::Vector3d& centre, const AutoRoiOptions& o,
                 RegionOfInterest* region) {
  std::vector<Eigen::Vector3d> local;
  for (const Eigen::Vector3d& p : landmarks)
    if (p.allFinite() && (p - centre).head<2>().norm() <= o.floor_radius_mm) local.push_back(p);
  PlaneSupport floor;
  if (!FitFloorPlane(local, o.floor_tolerance_mm, o.max_floor_tilt_deg, o.min_floor_points, o.ransac_iterations,
                     &floor))
    return 0;
  region->has_floor = true;
  region->floor = floor.plane;
  region->floor_clearance_mm = o.floor_clearance_mm;
  return floor.inliers;
}

bool AutoRegionOfInterest(const std::vector<int64_t>& ids, const std::vector<Eigen::Vector3d>& landmarks,
                          const std::unordered_map<int64_t, int>& central_counts, const AutoRoiOptions& o,
                          RegionOfInterest* roi, AutoRoiStats* stats_out) {
  AutoRoiStats stats;
  *roi = RegionOfInterest{};
  auto finish = [&](bool ok) {
    if (stats_out) *stats_out = stats;
    return ok;
  };
  const size_t n = std::min(ids.size(), landmarks.size());
  stats.landmarks = static_cast<int>(n);
  std::vector<Eigen::Vector3d> central;
  for (size_t i = 0; i < n; ++i) {
    if (!landmarks[i].allFinite()) continue;
    auto it = central_counts.find(ids[i]);
    if (it != central_counts.end() && it->second >= o.min_central_views) central.push_back(landmarks[i]);
  }
  stats.central = static_cast<int>(central.size());
  if (static_cast<int>(central.size()) < o.min_central_landmarks) return finish(false);
  auto median_point = [](const std::vector<Eigen::Vector3d>& pts) {
    Eigen::Vector3d m;
    for (int k = 0; k < 3; ++k) {
      std::vector<double> c;
      c.reserve(pts.size());
      for (const Eigen::Vector3d& p : pts) c.push_back(p[k]);
      m[k] = Median(std::move(c));
    }
    return m;
  };
  const Eigen::Vector3d centre0 = median_point(central);

  // Floor among the landmarks around the object.
  RegionOfInterest region;
  if (o.detect_floor) {
    std::vector<Eigen::Vector3d> finite;
    finite.reserve(n);
    for (size_t i = 0; i < n; ++i)
      if (landmarks[i].allFinite()) finite.push_back(landmarks[i]);
    stats.floor_inliers = AddFloorNear(finite, centre0, o, &region);
  }
  std::vector<Eigen::Vector3d> above;
  for (const Eigen::Vector3d& p : central)
    if (!region.has_floor || region.HeightAboveFloor(p) >= region.floor_clearance_mm) above.push_back(p);
  stats.above_floor = static_cast<int>(above.size());
  if (static_cast<int>(above.size()) < o.min_central_landmarks) return finish(false);

  // Robust cluster around the median.
  const Eigen::Vector3d centre = median_point(above);
  std::vector<double> dist;
  dist.reserve(above.size());
  for (const Eigen::Vector3d& p : above) dist.push_back((p - centre).norm());
  const double limit = o.cluster_k * Median(dist);
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (size_t i = 0; i < above.size(); ++i) {
    if (dist[i] > limit) continue;
    lo = lo.cwiseMin(above[i]);
    hi = hi.cwiseMax(above[i]);
    ++stats.cluster;
  }
  if (stats.cluster < 3) return finish(false);
  for (int k = 0; k < 3; ++k) {
    const double grow = std::max(o.margin_mm, o.margin_fraction * (hi[k] - lo[k]));
    lo[k] -= grow;
    hi[k] += grow;
  }
  region.valid = true;
  region.box_min = lo;
  region.box_max = hi;
  *roi = region;
  return finish(true);
}

bool ParseRoiBox(const std::string& text, RegionOfInterest* roi, std::string* why) {
  *roi = RegionOfInterest{};
  if (text.empty()) return true;
  std::vector<double> v;
  if (!ParseNumberList(text, &v)) {
    if (why) *why = "roi box: '" + text + "' is not a list of numbers xmin,ymin,zmin,xmax,ymax,zmax (mm)";
    return false;
  }
  if (v.size() != 6) {
    if (why) *why = "roi box needs 6 numbers xmin,ymin,zmin,xmax,ymax,zmax (mm)";
    return false;
  }
  for (int k = 0; k < 3; ++k) {
    if (!(v[k] < v[k + 3])) {
      if (why) *why = "roi box: min must be < max on every axis";
      return false;
    }
    roi->box_min[k] = v[k];
    roi->box_max[k] = v[k + 3];
  }
  roi->valid = true;
  return true;
}

RegionOfInterest TransformRegion(const RegionOfInterest& region, const Sim3& sim) {
  RegionOfInterest out = region;
  if (!region.valid) return out;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d c((corner & 1) ? region.box_max.x() : region.box_min.x(),
                            (corner & 2) ? region.box_max.y() : region.box_min.y(),
                            (corner & 4) ? region.box_max.z() : region.box_min.z());
    const Eigen::Vector3d m = sim * c;
    lo = lo.cwiseMin(m);
    hi = hi.cwiseMax(m);
  }
  out.box_min = lo;
  out.box_max = hi;
  if (region.has_floor) {  // n'.x' + o' = s (n.x + o) with x' = s R x + t, n' = R n: o' = s o - n'.t
    out.floor.normal = (sim.rotation * region.floor.normal).normalized();
    out.floor.offset_mm = sim.scale * region.floor.offset_mm - out.floor.normal.dot(sim.translation);
    out.floor_clearance_mm = sim.scale * region.floor_clearance_mm;
  }
  return out;
}

}  // namespace objscan
