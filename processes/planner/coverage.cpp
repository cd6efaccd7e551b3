#include "processes/planner/coverage.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace objscan {
namespace {

struct CellKey {
  int64_t x, y, z;
  bool operator==(const CellKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct CellKeyHash {
  size_t operator()(const CellKey& k) const {
    return static_cast<size_t>(k.x * 73856093LL) ^ static_cast<size_t>(k.y * 19349663LL) ^
           static_cast<size_t>(k.z * 83492791LL);
  }
};
CellKey KeyOf(const Eigen::Vector3d& p, double cell) {
  return {static_cast<int64_t>(std::floor(p.x() / cell)), static_cast<int64_t>(std::floor(p.y() / cell)),
          static_cast<int64_t>(std::floor(p.z() / cell))};
}

using PointHash = std::unordered_map<CellKey, std::vector<int>, CellKeyHash>;

// Indices of points within radius of p (the hash's cell must be >= radius).
template <class F>
void ForNeighbours(const PointHash& hash, const std::vector<Eigen::Vector3d>& points, double cell,
                   const Eigen::Vector3d& p, double radius, F&& f) {
  const CellKey k = KeyOf(p, cell);
  for (int64_t dz = -1; dz <= 1; ++dz)
    for (int64_t dy = -1; dy <= 1; ++dy)
      for (int64_t dx = -1; dx <= 1; ++dx) {
        const auto it = hash.find({k.x + dx, k.y + dy, k.z + dz});
        if (it == hash.end()) continue;
        for (int i : it->second)
          if ((points[i] - p).squaredNorm() <= radius * radius) f(i);
      }
}

}  // namespace

bool TargetBox::IsValid() const {
  return centre_mm.allFinite() && size_mm.allFinite() && std::isfinite(yaw_rad) && (size_mm.array() > 0).all();
}

CameraView CameraView::From(const Eigen::Isometry3d& world_from_camera) {
  CameraView v;
  v.camera_from_world = world_from_camera.inverse();
  v.position_mm = world_from_camera.translation();
  return v;
}

CoverageModel::CoverageModel(const CoverageOptions& options)
    : options_(options), cos_max_incidence_(std::cos(options.max_incidence_deg * M_PI / 180.0)) {}

void CoverageModel::SetCamera(const CameraIntrinsics& camera) {
  if (!camera.IsValid()) return;
  if (camera.width == camera_.width && camera.height == camera_.height && camera.fx == camera_.fx &&
      camera.fy == camera_.fy && camera.cx == camera_.cx && camera.cy == camera_.cy)
    return;
  camera_ = camera;
  views_counted_ = 0;
  for (SurfaceSample& s : samples_) s.views = 0;
}

void CoverageModel::SetTarget(const TargetBox& box) {
  if (!box.IsValid()) return;
  if (has_target_ && (box.centre_mm - target_.centre_mm).norm() < 5 && (box.size_mm - target_.size_mm).norm() < 5 &&
      std::abs(WrapAngle(box.yaw_rad - target_.yaw_rad)) < 0.05)
    return;
  target_ = box;
  has_target_ = true;
  samples_dirty_ = true;
}

void CoverageModel::SetVoxels(const VoxelCloud& voxels) {
  voxels_ = voxels;
  samples_dirty_ = true;
}

bool CoverageModel::AddView(const Eigen::Isometry3d& world_from_camera) {
  if (!world_from_camera.matrix().allFinite()) return false;
  if (!views_.empty()) {
    const CameraView& last = views_.back();
    const double moved = (world_from_camera.translation() - last.position_mm).norm();
    const Eigen::Matrix3d relative = last.camera_from_world.linear() * world_from_camera.linear();
    const double turned = Eigen::AngleAxisd(relative).angle();
    if (moved < options_.min_view_step_mm && turned < options_.min_view_turn_deg * M_PI / 180.0) return false;
  }
  views_.push_back(CameraView::From(world_from_camera));
  return true;
}

void CoverageModel::RebuildSamples() {
  samples_.clear();
  views_counted_ = 0;
  if (!has_target_) return;
  const double s = options_.sample_mm;
  const Eigen::Matrix3d world_from_box = Eigen::AngleAxisd(target_.yaw_rad, Eigen::Vector3d::UnitZ()).matrix();
  const Eigen::Vector3d half = 0.5 * target_.size_mm;
  const Eigen::Vector3d grown = half + Eigen::Vector3d::Constant(options_.region_margin_mm);
  // The target's voxels.
  std::vector<Eigen::Vector3d> points;
  for (const Eigen::Vector3d& v : voxels_.centres_mm) {
    if (!v.allFinite() || v.z() < options_.floor_clearance_mm) continue;
    const Eigen::Vector3d local = world_from_box.transpose() * (v - target_.centre_mm);
    if ((local.cwiseAbs().array() <= grown.array()).all()) points.push_back(v);
  }
  const double radius = 1.5 * s;
  PointHash by_point;
  for (int i = 0; i < static_cast<int>(points.size()); ++i) by_point[KeyOf(points[i], radius)].push_back(i);
  // One sample per s-cube: the mean of its voxels.
  std::unordered_map<CellKey, std::pair<Eigen::Vector3d, int>, CellKeyHash> cubes;
  for (const Eigen::Vector3d& p : points) {
    auto it = cubes.try_emplace(KeyOf(p, s), Eigen::Vector3d::Zero(), 0).first;
    it->second.first += p;
    ++it->second.second;
  }
  std::vector<Eigen::Vector3d> voxel_samples;
  for (auto& [key, c] : cubes) voxel_samples.push_back(c.first / c.second);
  std::sort(voxel_samples.begin(), voxel_samples.end(), [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    return std::tie(a.x(), a.y(), a.z()) < std::tie(b.x(), b.y(), b.z());
  });  // deterministic order
  for (const Eigen::Vector3d& p : voxel_samples) {
    SurfaceSample sample;
    sample.position_mm = p;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    std::vector<int> near;
    ForNeighbours(by_point, points, radius, p, radius, [&](int i) { near.push_back(i); });
    const Eigen::Vector3d outward = p - target_.centre_mm;
    Eigen::Vector3d normal = outward.norm() > 0 ? outward.normalized() : Eigen::Vector3d::UnitZ();
    if (near.size() >= 4) {
      for (int i : near) mean += points[i];
      mean /= static_cast<double>(near.size());
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
      for (int i : near) cov += (points[i] - mean) * (points[i] - mean).transpose();
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(cov);
      if (solver.info() == Eigen::Success) normal = solver.eigenvectors().col(0).normalized();
      if (normal.dot(outward) < 0) normal = -normal;
    }
    sample.normal = normal;
    samples_.push_back(sample);
  }
  // Box faces without voxel samples nearby: top (+z) and the four sides.
  PointHash by_sample;
  for (int i = 0; i < static_cast<int>(voxel_samples.size()); ++i)
    by_sample[KeyOf(voxel_samples[i], radius)].push_back(i);
  const Eigen::Vector3d faces[5] = {Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitX(), -Eigen::Vector3d::UnitX(),
                                    Eigen::Vector3d::UnitY(), -Eigen::Vector3d::UnitY()};
  for (const Eigen::Vector3d& n : faces) {
    const int axis = n.z() != 0 ? 2 : (n.x() != 0 ? 0 : 1);
    const int a = (axis + 1) % 3, b = (axis + 2) % 3;
    const int na = std::max(1, static_cast<int>(std::round(target_.size_mm[a] / s)));
    const int nb = std::max(1, static_cast<int>(std::round(target_.size_mm[b] / s)));
    for (int i = 0; i < na; ++i)
      for (int j = 0; j < nb; ++j) {
        Eigen::Vector3d local = n.cwiseProduct(half);
        local[a] = -half[a] + (i + 0.5) * target_.size_mm[a] / na;
        local[b] = -half[b] + (j + 0.5) * target_.size_mm[b] / nb;
        const Eigen::Vector3d p = target_.centre_mm + world_from_box * local;
        if (p.z() < options_.floor_clearance_mm) continue;
        bool near_voxel = false;
        ForNeighbours(by_sample, voxel_samples, radius, p, radius, [&](int) { near_voxel = true; });
        if (near_voxel) continue;
        SurfaceSample sample;
        sample.position_mm = p;
        sample.normal = world_from_box * n;
        sample.from_box = true;
        samples_.push_back(sample);
      }
  }
}

void CoverageModel::Update() {
  if (samples_dirty_) {
    RebuildSamples();
    samples_dirty_ = false;
  }
  for (; views_counted_ < views_.size(); ++views_counted_) {
    const CameraView& view = views_[views_counted_];
    for (SurfaceSample& sample : samples_)
      if (sample.views < options_.views_needed && Sees(view, sample)) ++sample.views;
  }
}

bool CoverageModel::Sees(const CameraView& view, const SurfaceSample& sample) const {
  const Eigen::Vector3d to_camera = view.position_mm - sample.position_mm;
  const double distance = to_camera.norm();
  if (!(distance > 0) || distance > options_.max_range_mm) return false;
  if (sample.normal.dot(to_camera) < cos_max_incidence_ * distance) return false;
  double u, v;
  return camera_.Project(view.camera_from_world * sample.position_mm, &u, &v) &&
         camera_.InImage(u, v, options_.image_margin_px);
}

int CoverageModel::num_covered() const {
  int n = 0;
  for (const SurfaceSample& s : samples_) n += s.views >= options_.views_needed;
  return n;
}

double CoverageModel::Fraction() const {
  return samples_.empty() ? 0.0 : static_cast<double>(num_covered()) / static_cast<double>(samples_.size());
}

int CoverageModel::CountUncoveredSeen(const CameraView& view) const {
  int n = 0;
  for (const SurfaceSample& s : samples_)
    if (s.views < options_.views_needed && Sees(view, s)) ++n;
  return n;
}

Eigen::Vector3d CoverageModel::UncoveredCentroid() const {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int n = 0;
  for (const SurfaceSample& s : samples_)
    if (s.views < options_.views_needed) {
      sum += s.position_mm;
      ++n;
    }
  return n > 0 ? Eigen::Vector3d(sum / n) : target_.centre_mm;
}

}  // namespace objscan
