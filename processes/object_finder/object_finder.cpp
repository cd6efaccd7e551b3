#include "processes/object_finder/object_finder.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>
#include <tuple>

namespace objscan {

namespace {

constexpr double kMinMapErrorPx = 0.05;      // px, the map error max_error_ratio scales is at least this
constexpr int kMinClusterPoints = 3;        // smaller groups are noise, never tracked
constexpr double kFreshFraction = 0.1;      // members seen again (at least 3) that make a cluster "observed" ...
constexpr double kFreshEnough = 20;         // ... or this many (a large cluster seen again after the camera looked
                                            // away: its old tracks ended, new landmarks come in tens per keyframe)
constexpr double kNeighbourFraction = 0.1;  // other points (at least 3) within the clearance that reject a target
constexpr int kForgetAfterUpdates = 20;     // a track no cluster continued for this many updates is forgotten

TargetBox ToTargetBox(const ClusterBox& b) { return TargetBox{b.centre_mm, b.size_mm, b.yaw_rad}; }

double HorizontalDistance(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::hypot(a.x() - b.x(), a.y() - b.y());
}

}  // namespace

const char* TargetStateName(TargetState state) {
  switch (state) {
    case TargetState::kSearching:
      return "searching";
    case TargetState::kCandidate:
      return "candidate";
    case TargetState::kConfirmed:
      return "confirmed";
    case TargetState::kLost:
      return "lost";
  }
  return "unknown";
}

bool ValidateObjectFinderOptions(const ObjectFinderOptions& o, std::string* why) {
  std::ostringstream e;
  auto positive = [&e](double v, const char* name) {
    if (!(v > 0) || !std::isfinite(v)) e << name << " must be > 0; ";
  };
  positive(o.floor_inlier_mm, "floor_inlier_mm");
  if (!(o.floor_max_tilt_deg > 0 && o.floor_max_tilt_deg < 90)) e << "floor_max_tilt_deg must be in (0, 90); ";
  if (o.min_floor_points < 3) e << "min_floor_points must be >= 3; ";
  if (!(o.look_closer_beyond_mm >= 0) || !std::isfinite(o.look_closer_beyond_mm))
    e << "look_closer_beyond_mm must be >= 0; ";
  if (!(o.look_closer_margin >= 0 && o.look_closer_margin <= 1)) e << "look_closer_margin must be in [0, 1]; ";
  if (o.min_observations < 0) e << "min_observations must be >= 0; ";
  positive(o.max_reprojection_error_px, "max_reprojection_error_px");
  if (!(o.max_error_ratio >= 1) || !std::isfinite(o.max_error_ratio)) e << "max_error_ratio must be >= 1; ";
  if (!(o.max_point_error_ratio >= o.max_error_ratio) || !std::isfinite(o.max_point_error_ratio))
    e << "max_point_error_ratio must be >= max_error_ratio; ";
  if (!(o.min_height_mm >= 0) || !std::isfinite(o.min_height_mm)) e << "min_height_mm must be >= 0; ";
  if (!(o.max_height_mm > o.min_height_mm) || !std::isfinite(o.max_height_mm))
    e << "max_height_mm must be > min_height_mm; ";
  positive(o.cluster_distance_mm, "cluster_distance_mm");
  positive(o.target_min_size_mm, "target-min-size");
  if (!(o.target_max_size_mm >= o.target_min_size_mm) || !std::isfinite(o.target_max_size_mm))
    e << "target-max-size must be >= target-min-size; ";
  if (!(o.size_tolerance >= 0 && o.size_tolerance < 1)) e << "size_tolerance must be in [0, 1); ";
  if (!(o.floor_contact_mm >= 0) || !std::isfinite(o.floor_contact_mm)) e << "floor_contact_mm must be >= 0; ";
  if (!(o.min_texture_density >= 0) || !std::isfinite(o.min_texture_density)) e << "min_texture_density must be >= 0; ";
  if (o.min_target_points < kMinClusterPoints) e << "min_target_points must be >= 3; ";
  if (!(o.clearance_mm >= 0) || !std::isfinite(o.clearance_mm)) e << "clearance_mm must be >= 0; ";
  positive(o.track_match_distance_mm, "track_match_distance_mm");
  if (o.min_views < 1) e << "min_views must be >= 1; ";
  if (!(o.min_view_baseline_mm >= 0) || !std::isfinite(o.min_view_baseline_mm))
    e << "min_view_baseline_mm must be >= 0; ";
  if (!(o.min_view_bearing_deg >= 0 && o.min_view_bearing_deg <= 180))
    e << "min_view_bearing_deg must be in [0, 180]; ";
  positive(o.max_centre_motion_mm, "max_centre_motion_mm");
  if (o.lost_after_updates < 1) e << "lost_after_updates must be >= 1; ";
  positive(o.max_view_distance_mm, "max_view_distance_mm");
  if (o.drop_after_rejections < 1) e << "drop_after_rejections must be >= 1; ";
  const std::string msg = e.str();
  if (msg.empty()) return true;
  if (why) *why = msg.substr(0, msg.size() - 2);
  return false;
}

bool FinderCamera::IsValid() const {
  return width > 0 && height > 0 && fx > 0 && fy > 0 && std::isfinite(fx) && std::isfinite(fy) && std::isfinite(cx) &&
         std::isfinite(cy);
}

bool BoxFromModel(const std::vector<Eigen::Vector3d>& voxels_mm, double voxel_mm, const FloorPlane& floor,
                  const TargetBox& near, TargetBox* box, int* voxels_used, std::string* why) {
  if (voxels_used) *voxels_used = 0;
  if (!(voxel_mm > 0) || !std::isfinite(voxel_mm)) {
    *why = "the model's voxel size is not positive";
    return false;
  }
  const Eigen::Isometry3d floor_from_world = floor.FloorFromWorld();
  std::vector<Eigen::Vector3d> above;  // floor frame
  for (const Eigen::Vector3d& v : voxels_mm) {
    if (!v.allFinite()) continue;
    const Eigen::Vector3d f = floor_from_world * v;
    if (f.z() > voxel_mm) above.push_back(f);
  }
  std::vector<std::vector<int>> clusters = EuclideanClusters(above, 2.5 * voxel_mm, kMinModelVoxels);
  if (clusters.empty()) {
    *why = std::to_string(above.size()) + " of " + std::to_string(voxels_mm.size()) +
           " voxels above the floor and no connected group of " + std::to_string(kMinModelVoxels);
    return false;
  }
  const auto largest = std::max_element(clusters.begin(), clusters.end(),
                                        [](const auto& a, const auto& b) { return a.size() < b.size(); });
  ClusterBox fitted = FitClusterBox(above, *largest, floor);
  // The top as the footprint's extents are measured: the 99 % quantile of the heights, not the highest voxel (carving
  // leaves a sparse fuzz over flat tops: room_03's cylinder, 232 mm high, had voxels up to 247.5 mm, 99 % below 238.6).
  std::vector<double> heights;
  heights.reserve(largest->size());
  for (int i : *largest) heights.push_back(above[i].z());
  const size_t k = static_cast<size_t>(0.99 * (heights.size() - 1));
  std::nth_element(heights.begin(), heights.begin() + static_cast<std::ptrdiff_t>(k), heights.end());
  const double top = heights[k];
  fitted.centre_mm += floor.normal * (0.5 * (top - fitted.size_mm.z()));
  fitted.size_mm.z() = top;
  const Eigen::Vector2d offset = (fitted.centre_mm - near.centre_mm).head<2>();
  const double c = std::cos(near.yaw_rad), s = std::sin(near.yaw_rad);
  const Eigen::Vector2d along(c * offset.x() + s * offset.y(), -s * offset.x() + c * offset.y());
  if (std::abs(along.x()) > near.size_mm.x() || std::abs(along.y()) > near.size_mm.y()) {
    char text[200];
    std::snprintf(text, sizeof(text), "the model's largest part (%zu voxels) is centred %.0f mm from the landmarks' box, "
                  "outside its footprint grown by half", largest->size(), offset.norm());
    *why = text;
    return false;
  }
  *box = ToTargetBox(fitted);
  if (voxels_used) *voxels_used = static_cast<int>(largest->size());
  return true;
}

ImageRegion ProjectBox(const TargetBox& box, const Eigen::Isometry3d& world_from_camera, const FinderCamera& camera) {
  if (!camera.IsValid()) return {};
  const Eigen::Isometry3d camera_from_world = world_from_camera.inverse();
  const Eigen::Matrix3d yaw = Eigen::AngleAxisd(box.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const double inf = std::numeric_limits<double>::infinity();
  double u_min = inf, u_max = -inf, v_min = inf, v_max = -inf;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d offset(corner & 1 ? 0.5 : -0.5, corner & 2 ? 0.5 : -0.5, corner & 4 ? 0.5 : -0.5);
    const Eigen::Vector3d p = camera_from_world * (box.centre_mm + yaw * offset.cwiseProduct(box.size_mm));
    if (!(p.z() > 1e-3)) continue;  // behind the camera
    const double u = camera.fx * p.x() / p.z() + camera.cx, v = camera.fy * p.y() / p.z() + camera.cy;
    u_min = std::min(u_min, u);
    u_max = std::max(u_max, u);
    v_min = std::min(v_min, v);
    v_max = std::max(v_max, v);
  }
  if (!(u_min <= u_max) || !(v_min <= v_max)) return {};
  // Pixel i covers [i - 0.5, i + 0.5); clamp in double first (corners near the camera plane project far away).
  auto first = [](double x, int size) { return static_cast<int>(std::floor(std::clamp(x, -1.0, size + 1.0) + 0.5)); };
  const int u0 = std::clamp(first(u_min, camera.width), 0, camera.width);
  const int u1 = std::clamp(first(u_max, camera.width) + 1, 0, camera.width);
  const int v0 = std::clamp(first(v_min, camera.height), 0, camera.height);
  const int v1 = std::clamp(first(v_max, camera.height) + 1, 0, camera.height);
  if (u1 <= u0 || v1 <= v0) return {};
  return ImageRegion{u0, v0, u1 - u0, v1 - v0};
}

ObjectFinder::ObjectFinder(const ObjectFinderOptions& options) : options_(options) {
  std::string why;
  if (!ValidateObjectFinderOptions(options_, &why)) throw std::invalid_argument("object finder: " + why);
}

bool ObjectFinder::Update(const FinderInput& input, std::string* error) {
  auto fail = [error](const std::string& why) {
    if (error) *error = why;
    return false;
  };
  if (!input.camera.IsValid()) return fail("invalid camera intrinsics");
  const Eigen::Matrix3d r = input.world_from_camera.linear();
  if (!input.world_from_camera.matrix().allFinite() ||
      !((r.transpose() * r - Eigen::Matrix3d::Identity()).norm() < 1e-6) || !(r.determinant() > 0))
    return fail("camera pose is not a finite rigid transform");
  std::vector<int> valid;
  const std::vector<char> fresh = CollectLandmarks(input, &valid);
  UpdateFloor(input, valid);
  std::vector<Cluster> clusters;
  if (floor_valid_) clusters = FindClusters(input, valid, fresh);
  MatchTracks(clusters);
  UpdateTracks(input, clusters);
  drop_reason_.clear();
  UpdateTarget(input);
  FillResult(input, clusters);
  ++updates_;
  return true;
}

std::vector<char> ObjectFinder::CollectLandmarks(const FinderInput& input, std::vector<int>* valid) {
  const std::vector<MapLandmark>& landmarks = input.landmarks;
  std::vector<char> fresh(landmarks.size(), 0);
  std::unordered_map<int64_t, int> current;
  current.reserve(landmarks.size());
  valid->reserve(landmarks.size());
  int rejected = 0;
  for (size_t i = 0; i < landmarks.size(); ++i) {
    const MapLandmark& l = landmarks[i];
    if (!l.position_mm.allFinite() || !(l.reprojection_error_px >= 0) || !std::isfinite(l.reprojection_error_px) ||
        l.num_observations < 0) {
      ++rejected;
      continue;
    }
    valid->push_back(static_cast<int>(i));
    const auto it = previous_observations_.find(l.id);
    fresh[i] = it == previous_observations_.end() || l.num_observations > it->second;
    current[l.id] = l.num_observations;
  }
  previous_observations_.swap(current);
  result_.rejected_landmarks = rejected;
  return fresh;
}

void ObjectFinder::UpdateFloor(const FinderInput& input, const std::vector<int>& valid) {
  std::vector<Eigen::Vector3d> points;
  points.reserve(valid.size());
  for (int i : valid) points.push_back(input.landmarks[i].position_mm);
  FloorFitOptions fit_options;
  fit_options.inlier_mm = options_.floor_inlier_mm;
  fit_options.max_tilt_deg = options_.floor_max_tilt_deg;
  fit_options.min_points = options_.min_floor_points;
  const FloorFit fit = FitFloor(points, fit_options, floor_valid_ ? &floor_ : nullptr);
  if (fit.found) {
    floor_ = fit.plane;
    floor_valid_ = true;
    floor_points_ = fit.inliers;
  } else if (floor_valid_) {  // too few floor points in this map: keep the last good floor
    floor_points_ = 0;
    for (const auto& p : points) floor_points_ += std::abs(floor_.Height(p)) <= options_.floor_inlier_mm;
  }
}

std::vector<ObjectFinder::Cluster> ObjectFinder::FindClusters(const FinderInput& input, const std::vector<int>& valid,
                                                              const std::vector<char>& fresh) {
  const Eigen::Isometry3d floor_from_world = floor_.FloorFromWorld();
  // The landmarks usable at all, and their median reprojection error (the map's, mostly the floor's): points much
  // worse than it are not points of a textured surface (see max_point_error_ratio) and are left out.
  std::vector<int> usable;
  std::vector<double> errors_px;
  for (int i : valid) {
    const MapLandmark& l = input.landmarks[i];
    if (l.num_observations < options_.min_observations || l.reprojection_error_px > options_.max_reprojection_error_px)
      continue;
    usable.push_back(i);
    errors_px.push_back(l.reprojection_error_px);
  }
  result_.map_error_px = 0;
  if (!errors_px.empty()) {
    std::nth_element(errors_px.begin(), errors_px.begin() + errors_px.size() / 2, errors_px.end());
    result_.map_error_px = errors_px[errors_px.size() / 2];
  }
  const double max_error_px = options_.max_point_error_ratio * std::max(result_.map_error_px, kMinMapErrorPx);
  std::vector<Eigen::Vector3d> floor_points;
  std::vector<double> point_errors_px;  // parallel to floor_points
  std::vector<int> source;              // index into input.landmarks
  result_.points_inconsistent = 0;
  for (int i : usable) {
    const MapLandmark& l = input.landmarks[i];
    const Eigen::Vector3d f = floor_from_world * l.position_mm;
    if (f.z() <= options_.min_height_mm || f.z() > options_.max_height_mm) continue;
    if (l.reprojection_error_px > max_error_px) {
      ++result_.points_inconsistent;
      continue;
    }
    floor_points.push_back(f);
    point_errors_px.push_back(l.reprojection_error_px);
    source.push_back(i);
  }
  result_.points_used = static_cast<int>(floor_points.size());
  const std::vector<std::vector<int>> groups =
      EuclideanClusters(floor_points, options_.cluster_distance_mm, kMinClusterPoints);
  std::vector<int> label(floor_points.size(), -1);
  for (size_t k = 0; k < groups.size(); ++k)
    for (int m : groups[k]) label[m] = static_cast<int>(k);
  std::vector<Cluster> clusters(groups.size());
  for (size_t k = 0; k < groups.size(); ++k) {
    Cluster& c = clusters[k];
    c.box = FitClusterBox(floor_points, groups[k], floor_, &point_errors_px);
    c.rejection = CheckRule(c.box);
    const bool size_only = (c.rejection == "too large" || c.rejection == "too high") &&
                           CheckRule(c.box, 1 + options_.look_closer_margin).empty();
    if ((c.rejection.empty() || size_only) &&
        CountNeighbours(floor_points, label, static_cast<int>(k), c.box) >
            std::max<double>(3, kNeighbourFraction * groups[k].size())) {
      if (c.rejection.empty()) c.rejection = "not isolated";
    } else {
      c.near_miss = size_only;
    }
  }
  std::vector<std::vector<int>> members = groups;
  MergeFragments(floor_points, point_errors_px, &label, &members, &clusters);
  for (size_t k = 0; k < clusters.size(); ++k) {
    Cluster& c = clusters[k];
    int fresh_members = 0;
    for (int m : members[k]) fresh_members += fresh[source[m]];
    c.observed = fresh_members >= std::max<double>(3, std::min(kFreshEnough, kFreshFraction * members[k].size()));
    c.in_view = InView(c.box.centre_mm, input, std::numeric_limits<double>::infinity());
  }
  return clusters;
}

// A small object seen sparsely (the robot drove past it, looking ahead) falls apart at cluster_distance_mm into
// pieces that reject each other as "not isolated" or are too small, too few or off the floor on their own
// (room_01: a 268 mm sphere in pieces of 20, 13 and 3 landmarks, never a candidate). Pieces rejected for such
// reasons are linked again at twice the distance; a group of pieces that passes the rule as a whole replaces them.
// Pieces of walls and tables merge into something too large or too high and stay as they were.
void ObjectFinder::MergeFragments(const std::vector<Eigen::Vector3d>& floor_points,
                                  const std::vector<double>& point_errors_px, std::vector<int>* label,
                                  std::vector<std::vector<int>>* members, std::vector<Cluster>* clusters) const {
  std::vector<int> fragment_points, fragment_of;  // indices into floor_points; the cluster each came from
  for (size_t k = 0; k < clusters->size(); ++k) {
    const std::string& why = (*clusters)[k].rejection;
    if (why != "not isolated" && why != "too few points" && why != "too small" && why != "too low" &&
        why != "not on the floor")
      continue;
    for (int m : (*members)[k]) {
      fragment_points.push_back(m);
      fragment_of.push_back(static_cast<int>(k));
    }
  }
  if (fragment_points.empty()) return;
  for (size_t m = 0; m < label->size(); ++m)  // stragglers: points in no cluster at all
    if ((*label)[m] < 0) {
      fragment_points.push_back(static_cast<int>(m));
      fragment_of.push_back(-1);
    }
  std::vector<Eigen::Vector3d> points;
  points.reserve(fragment_points.size());
  for (int m : fragment_points) points.push_back(floor_points[m]);
  const std::vector<std::vector<int>> groups =
      EuclideanClusters(points, 2 * options_.cluster_distance_mm, kMinClusterPoints);
  std::vector<char> replaced(clusters->size(), 0);
  for (const std::vector<int>& group : groups) {
    std::set<int> pieces;
    std::vector<int> merged;
    for (int g : group) {
      if (fragment_of[g] >= 0) pieces.insert(fragment_of[g]);
      merged.push_back(fragment_points[g]);
    }
    if (pieces.size() < 2) continue;
    std::sort(merged.begin(), merged.end());
    Cluster c;
    c.box = FitClusterBox(floor_points, merged, floor_, &point_errors_px);
    c.rejection = CheckRule(c.box);
    if (!c.rejection.empty()) continue;
    const int new_label = static_cast<int>(clusters->size());
    std::vector<int> saved;
    for (int m : merged) {
      saved.push_back((*label)[m]);
      (*label)[m] = new_label;
    }
    if (CountNeighbours(floor_points, *label, new_label, c.box) >
        std::max<double>(3, kNeighbourFraction * merged.size())) {
      for (size_t i = 0; i < merged.size(); ++i) (*label)[merged[i]] = saved[i];
      continue;
    }
    for (int piece : pieces) replaced[piece] = 1;
    clusters->push_back(c);
    members->push_back(merged);
    replaced.push_back(0);
  }
  // Drop the replaced pieces (labels of the remaining clusters follow their new index).
  std::vector<Cluster> kept_clusters;
  std::vector<std::vector<int>> kept_members;
  for (size_t k = 0; k < clusters->size(); ++k) {
    if (replaced[k]) continue;
    for (int m : (*members)[k]) (*label)[m] = static_cast<int>(kept_clusters.size());
    kept_clusters.push_back((*clusters)[k]);
    kept_members.push_back((*members)[k]);
  }
  *clusters = std::move(kept_clusters);
  *members = std::move(kept_members);
}

std::string ObjectFinder::CheckRule(const ClusterBox& box, double size_scale) const {
  const double low = options_.target_min_size_mm * (1 - options_.size_tolerance);
  const double high = options_.target_max_size_mm * (1 + options_.size_tolerance) * size_scale;
  const double horizontal = std::max(box.size_mm.x(), box.size_mm.y());
  if (box.size_mm.z() > high) return "too high";
  if (horizontal > high) return "too large";
  if (box.size_mm.z() < low) return "too low";
  if (horizontal < low) return "too small";
  if (box.lowest_mm > options_.floor_contact_mm) return "not on the floor";
  if (box.points < options_.min_target_points) return "too few points";
  if (box.texture_density < options_.min_texture_density) return "untextured";
  if (box.median_error_px > options_.max_error_ratio * std::max(result_.map_error_px, kMinMapErrorPx))
    return "outline only";
  return "";
}

int ObjectFinder::CountNeighbours(const std::vector<Eigen::Vector3d>& floor_points, const std::vector<int>& label,
                                  int cluster, const ClusterBox& box) const {
  const Eigen::Vector3d centre = floor_.FloorFromWorld() * box.centre_mm;
  const Eigen::Vector2d a(std::cos(box.yaw_rad), std::sin(box.yaw_rad)), b(-a.y(), a.x());
  const double half_a = 0.5 * box.size_mm.x() + options_.clearance_mm;
  const double half_b = 0.5 * box.size_mm.y() + options_.clearance_mm;
  const double top = box.size_mm.z() + options_.clearance_mm;
  int count = 0;
  for (size_t i = 0; i < floor_points.size(); ++i) {
    if (label[i] == cluster) continue;
    const Eigen::Vector2d d = floor_points[i].head<2>() - centre.head<2>();
    count += std::abs(d.dot(a)) <= half_a && std::abs(d.dot(b)) <= half_b && floor_points[i].z() <= top &&
             floor_points[i].z() > options_.floor_contact_mm;
  }
  return count;
}

bool ObjectFinder::InView(const Eigen::Vector3d& centre, const FinderInput& input, double max_distance) const {
  const Eigen::Vector3d p = input.world_from_camera.inverse() * centre;
  if (!(p.z() > 1.0) || p.norm() > max_distance) return false;
  const double u = input.camera.fx * p.x() / p.z() + input.camera.cx;
  const double v = input.camera.fy * p.y() / p.z() + input.camera.cy;
  return u >= -0.5 && v >= -0.5 && u <= input.camera.width - 0.5 && v <= input.camera.height - 0.5;
}

bool ObjectFinder::Occluded(const Eigen::Vector3d& centre, int own, const FinderInput& input,
                            const std::vector<Cluster>& clusters) const {
  const Eigen::Vector3d camera = input.world_from_camera.translation();
  const double length = (centre - camera).norm();
  constexpr double kStepMm = 20, kMarginMm = 20;
  // Samples from 100 mm in front of the camera to 85 % of the way (the target's own box is left out anyway).
  for (double s = 100; s < 0.85 * length; s += kStepMm) {
    const Eigen::Vector3d p = camera + (centre - camera) * (s / length);
    const double height = floor_.Height(p);
    for (size_t k = 0; k < clusters.size(); ++k) {
      if (static_cast<int>(k) == own) continue;
      const ClusterBox& b = clusters[k].box;
      if (height > b.size_mm.z()) continue;
      const Eigen::Vector2d d =
          Eigen::Rotation2Dd(-b.yaw_rad) * (p.head<2>() - b.centre_mm.head<2>());
      if (std::abs(d.x()) <= 0.5 * b.size_mm.x() + kMarginMm && std::abs(d.y()) <= 0.5 * b.size_mm.y() + kMarginMm)
        return true;
    }
  }
  return false;
}

void ObjectFinder::MatchTracks(const std::vector<Cluster>& clusters) {
  for (Track& t : tracks_) {
    t.matched = false;
    t.cluster = -1;
  }
  std::vector<std::tuple<double, int, int>> pairs;  // distance, track index, cluster index
  for (size_t ti = 0; ti < tracks_.size(); ++ti)
    for (size_t ci = 0; ci < clusters.size(); ++ci) {
      const double d = HorizontalDistance(tracks_[ti].box.centre_mm, clusters[ci].box.centre_mm);
      if (d <= options_.track_match_distance_mm) pairs.emplace_back(d, static_cast<int>(ti), static_cast<int>(ci));
    }
  // The confirmed target's track first (its nearest observed cluster, else its nearest), then the others nearest
  // first: when the map drops the target's landmarks and the object is a cluster nearer to another track (room_03:
  // the target's own cluster went stale, the object was a second track's cluster 78 mm away), the target keeps the
  // object instead of being left unmatched, missed and lost for good.
  std::sort(pairs.begin(), pairs.end(), [this, &clusters](const auto& a, const auto& b) {
    const bool ta = tracks_[std::get<1>(a)].id == target_id_, tb = tracks_[std::get<1>(b)].id == target_id_;
    if (ta != tb) return ta;
    if (ta) {
      const bool oa = clusters[std::get<2>(a)].observed, ob = clusters[std::get<2>(b)].observed;
      if (oa != ob) return oa;
    }
    return a < b;
  });
  std::vector<char> cluster_taken(clusters.size(), 0);
  for (const auto& [d, ti, ci] : pairs) {
    if (tracks_[ti].matched || cluster_taken[ci]) continue;
    tracks_[ti].matched = true;
    tracks_[ti].cluster = ci;
    cluster_taken[ci] = 1;
  }
  for (size_t ci = 0; ci < clusters.size(); ++ci) {
    if (cluster_taken[ci]) continue;
    Track t;
    t.id = next_track_id_++;
    t.box = clusters[ci].box;
    t.matched = true;
    t.cluster = static_cast<int>(ci);
    tracks_.push_back(t);
  }
}

void ObjectFinder::UpdateTracks(const FinderInput& input, const std::vector<Cluster>& clusters) {
  const Eigen::Vector3d camera = input.world_from_camera.translation();
  const double min_bearing_cos = std::cos(options_.min_view_bearing_deg * M_PI / 180.0);
  for (Track& t : tracks_) {
    t.seen = t.matched && clusters[t.cluster].observed;
    if (!t.matched) {
      t.passes = false;
      t.look_closer = false;
      ++t.unmatched_updates;
    } else {
      const Cluster& c = clusters[t.cluster];
      t.box = c.box;
      t.passes = c.rejection.empty();
      t.unmatched_updates = 0;
      if (t.seen) t.nearest_seen_mm = std::min(t.nearest_seen_mm, (camera - c.box.centre_mm).norm());
      t.look_closer = !t.passes && c.near_miss && t.nearest_seen_mm > options_.look_closer_beyond_mm;
      if (t.passes) t.passing_box = c.box;
      if (t.seen && c.in_view && t.passes) {
        t.rejected_run = 0;
        const View view{camera, (camera - c.box.centre_mm).normalized()};
        const bool distinct = std::all_of(t.views.begin(), t.views.end(), [&](const View& w) {
          return (view.camera_mm - w.camera_mm).norm() >= options_.min_view_baseline_mm ||
                 view.direction.dot(w.direction) <= min_bearing_cos;
        });
        if (distinct) {
          t.views.push_back(view);
          t.recent_centres.push_back(c.box.centre_mm);
          if (static_cast<int>(t.recent_centres.size()) > options_.min_views)
            t.recent_centres.erase(t.recent_centres.begin());
        }
      } else if (t.seen && c.in_view) {
        ++t.rejected_run;
        t.last_rejection = c.rejection;
      }
    }
    if (t.seen)
      t.missed_run = 0;
    else if (InView(t.box.centre_mm, input, options_.max_view_distance_mm) &&
             !Occluded(t.box.centre_mm, t.matched ? t.cluster : -1, input, clusters))
      ++t.missed_run;
  }
  tracks_.erase(std::remove_if(
                    tracks_.begin(), tracks_.end(),
                    [this](const Track& t) { return t.id != target_id_ && t.unmatched_updates > kForgetAfterUpdates; }),
                tracks_.end());
}

bool ObjectFinder::IsCandidate(const Track& t) const {
  return t.matched && ((t.passes && !t.views.empty()) || t.look_closer) &&
         t.missed_run < options_.lost_after_updates;
}

bool ObjectFinder::IsConfirmable(const Track& t) const {
  if (!IsCandidate(t) || !t.passes || static_cast<int>(t.views.size()) < options_.min_views ||
      static_cast<int>(t.recent_centres.size()) < options_.min_views)
    return false;
  for (const auto& c : t.recent_centres)
    if ((c - t.box.centre_mm).norm() > options_.max_centre_motion_mm) return false;
  return true;
}

std::string ObjectFinder::WhyNotConfirmable(const Track& t, const std::vector<Cluster>& clusters) const {
  std::string why;
  auto add = [&why](const std::string& part) { why += (why.empty() ? "" : "; ") + part; };
  char text[200];
  if (!t.passes) {
    const bool have_cluster = t.matched && t.cluster >= 0 && t.cluster < static_cast<int>(clusters.size());
    add("fails the rule now" + (have_cluster && !clusters[t.cluster].rejection.empty()
                                     ? " (" + clusters[t.cluster].rejection + ")"
                                     : std::string(t.look_closer ? " (a little too large from afar: look closer)" : "")));
  }
  if (static_cast<int>(t.views.size()) < options_.min_views) {
    std::snprintf(text, sizeof(text), "%zu of %d views (a view: observed, in view, passing, %.0f mm or %.0f deg from "
                  "the others)", t.views.size(), options_.min_views, options_.min_view_baseline_mm,
                  options_.min_view_bearing_deg);
    add(text);
  }
  double moved = 0;
  for (const auto& c : t.recent_centres) moved = std::max(moved, (c - t.box.centre_mm).norm());
  if (moved > options_.max_centre_motion_mm) {
    std::snprintf(text, sizeof(text), "centre moved %.0f mm over its last views (max %.0f)", moved,
                  options_.max_centre_motion_mm);
    add(text);
  }
  if (!t.seen) add("not observed in this update");
  return why;
}

double ObjectFinder::Distance(const FinderInput& input, const Track& t) const {
  if (!input.has_robot_position || !input.robot_xy_mm.allFinite()) return -1;
  return std::hypot(t.box.centre_mm.x() - input.robot_xy_mm.x(), t.box.centre_mm.y() - input.robot_xy_mm.y());
}

template <class Pred>
int ObjectFinder::Best(const FinderInput& input, Pred accept) const {
  int best = -1;
  for (size_t i = 0; i < tracks_.size(); ++i) {
    const Track& t = tracks_[i];
    if (!accept(t)) continue;
    if (best < 0) {
      best = static_cast<int>(i);
      continue;
    }
    const Track& b = tracks_[best];
    const double dt = Distance(input, t), db = Distance(input, b);
    const bool better =
        dt >= 0 ? dt < db
                : (t.views.size() != b.views.size() ? t.views.size() > b.views.size() : t.box.points > b.box.points);
    if (better) best = static_cast<int>(i);  // ties keep the older track
  }
  return best;
}

ObjectFinder::Track* ObjectFinder::FindTrack(int id) {
  for (Track& t : tracks_)
    if (t.id == id) return &t;
  return nullptr;
}

void ObjectFinder::UpdateTarget(const FinderInput& input) {
  if (Track* t = target_id_ >= 0 ? FindTrack(target_id_) : nullptr) {
    if (t->rejected_run >= options_.drop_after_rejections) {  // the views say it is not a target after all
      std::ostringstream why;
      why << (t->last_rejection.empty() ? "failed the rule" : t->last_rejection) << " in " << t->rejected_run
          << " views in a row (box " << std::lround(t->box.size_mm.x()) << "x" << std::lround(t->box.size_mm.y())
          << "x" << std::lround(t->box.size_mm.z()) << " mm, " << t->box.points << " points)";
      drop_reason_ = why.str();
      t->views.clear();
      t->recent_centres.clear();
      target_id_ = -1;
      target_lost_ = false;
      confirmed_seq_ = -1;
      confirmed_utime_ = 0;
    } else if (t->seen && t->passes) {
      target_lost_ = false;
    } else if (t->missed_run >= options_.lost_after_updates) {
      target_lost_ = true;
    }
    if (target_id_ >= 0) return;
  }
  const int best = Best(input, [this](const Track& t) { return IsConfirmable(t); });
  if (best < 0) return;
  target_id_ = tracks_[best].id;
  target_lost_ = false;
  confirmed_seq_ = input.seq;
  confirmed_utime_ = input.utime;
}

void ObjectFinder::FillResult(const FinderInput& input, const std::vector<Cluster>& clusters) {
  FinderResult& r = result_;
  r.utime = input.utime;
  r.seq = input.seq;
  r.floor_valid = floor_valid_;
  r.floor = floor_;
  r.floor_points = floor_points_;
  r.clusters.assign(clusters.size(), ClusterReport{});
  for (size_t ci = 0; ci < clusters.size(); ++ci) {
    r.clusters[ci].box = clusters[ci].box;
    r.clusters[ci].passes = clusters[ci].rejection.empty();
    r.clusters[ci].rejection = clusters[ci].rejection;
    r.clusters[ci].in_view = clusters[ci].in_view;
    r.clusters[ci].observed = clusters[ci].observed;
  }
  for (const Track& t : tracks_)
    if (t.matched) r.clusters[t.cluster].track_id = t.id;

  const int n = options_.min_views;
  const Track* target = nullptr;
  r.not_confirmed_why.clear();
  r.state = TargetState::kSearching;
  r.confidence = 0;
  if (target_id_ >= 0 && (target = FindTrack(target_id_))) {
    r.state = target_lost_ ? TargetState::kLost : TargetState::kConfirmed;
    r.box = ToTargetBox(target->passing_box);
    const double views = std::max<double>(n, static_cast<double>(target->views.size()));
    r.confidence = (1.0 - 0.5 * n / views) * (target_lost_ ? 0.5 : 1.0);
  } else {
    const int best = Best(input, [this](const Track& t) { return IsCandidate(t); });
    if (best >= 0) {
      target = &tracks_[best];
      r.state = TargetState::kCandidate;
      r.box = ToTargetBox(target->box);
      r.not_confirmed_why = WhyNotConfirmable(*target, clusters);
      r.confidence = 0.4 * std::min<double>(n, static_cast<double>(target->views.size())) / n;
    }
  }
  r.track_id = target ? target->id : -1;
  r.views = target ? static_cast<int>(target->views.size()) : 0;
  r.points = target ? target->box.points : 0;
  if (!target) r.box = TargetBox{};
  r.roi = target ? ProjectBox(r.box, input.world_from_camera, input.camera) : ImageRegion{};
  r.drop_reason = drop_reason_;
  r.confirmed_seq = confirmed_seq_;
  r.confirmed_utime = confirmed_utime_;

  r.other_candidates.clear();
  r.candidates = 0;
  for (const Track& t : tracks_) {
    if (!IsCandidate(t)) continue;
    ++r.candidates;
    if (target && t.id == target->id) continue;
    r.other_candidates.push_back(
        CandidateReport{t.id, ToTargetBox(t.box), t.box.points, static_cast<int>(t.views.size()), Distance(input, t)});
  }
  std::stable_sort(r.other_candidates.begin(), r.other_candidates.end(),
                   [](const CandidateReport& a, const CandidateReport& b) {
                     return a.distance_mm >= 0 ? a.distance_mm < b.distance_mm : a.views > b.views;
                   });
}

}  // namespace objscan
