#include "processes/planner/occupancy_map.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace objscan {
namespace {

constexpr float kFar = 1e30f;

// 1-D squared distance transform of f (kFar = no site) into d; only finite entries are parabola sites.
void DistanceTransform1d(const float* f, int n, float* d, std::vector<int>& v, std::vector<double>& z) {
  int k = -1;
  for (int q = 0; q < n; ++q) {
    if (f[q] >= kFar) continue;
    const double fq = f[q] + static_cast<double>(q) * q;
    while (k >= 0) {
      const int p = v[k];
      const double s = (fq - (f[p] + static_cast<double>(p) * p)) / (2.0 * (q - p));
      if (s <= z[k]) {
        --k;
      } else {
        break;
      }
    }
    ++k;
    v[k] = q;
    z[k] = k == 0 ? -std::numeric_limits<double>::infinity()
                  : (fq - (f[v[k - 1]] + static_cast<double>(v[k - 1]) * v[k - 1])) / (2.0 * (q - v[k - 1]));
  }
  if (k < 0) {
    std::fill(d, d + n, kFar);
    return;
  }
  int j = 0;
  for (int q = 0; q < n; ++q) {
    while (j < k && z[j + 1] < q) ++j;
    const double dq = q - v[j];
    d[q] = static_cast<float>(dq * dq + f[v[j]]);
  }
}

}  // namespace

void SquaredDistanceToSites(const std::vector<uint8_t>& is_site, int w, int h, std::vector<float>* squared) {
  std::vector<float>& out = *squared;
  out.assign(static_cast<size_t>(w) * h, kFar);
  const int n = std::max(w, h);
  std::vector<float> f(n), d(n);
  std::vector<int> v(n);
  std::vector<double> z(n + 1);
  for (int x = 0; x < w; ++x) {  // columns
    for (int y = 0; y < h; ++y) f[y] = is_site[static_cast<size_t>(y) * w + x] ? 0.f : kFar;
    DistanceTransform1d(f.data(), h, d.data(), v, z);
    for (int y = 0; y < h; ++y) out[static_cast<size_t>(y) * w + x] = d[y];
  }
  for (int y = 0; y < h; ++y) {  // rows
    float* row = out.data() + static_cast<size_t>(y) * w;
    std::copy(row, row + w, f.begin());
    DistanceTransform1d(f.data(), w, d.data(), v, z);
    std::copy(d.begin(), d.begin() + w, row);
  }
}

bool ValidateOccupancyMapOptions(const OccupancyMapOptions& o, std::string* why) {
  std::ostringstream e;
  auto positive = [&](double value, const char* name) {
    if (!(value > 0) || !std::isfinite(value)) e << name << " must be > 0; ";
  };
  positive(o.cell_mm, "map cell");
  positive(o.size_mm, "map size");
  positive(o.view_range_mm, "view range");
  positive(o.footprint_radius_mm, "footprint radius");
  positive(o.floor_band_mm, "floor band");
  if (o.cell_mm > 0 && o.size_mm / o.cell_mm > 4000) e << "map size / cell must be <= 4000 cells per side; ";
  if (o.cell_mm > 0 && o.size_mm > 0 && o.size_mm / o.cell_mm < 8) e << "map must be >= 8 cells per side; ";
  if (!(o.obstacle_max_z_mm > o.obstacle_min_z_mm)) e << "obstacle max z must be > obstacle min z; ";
  if (!(o.obstacle_min_z_mm >= o.floor_band_mm)) e << "obstacle min z must be >= the floor band; ";
  if (!(o.free_support_mm >= 0) || !std::isfinite(o.free_support_mm)) e << "free support must be >= 0; ";
  if (!(o.safety_margin_mm >= 0) || !std::isfinite(o.safety_margin_mm)) e << "safety margin must be >= 0; ";
  if (o.min_observations < 0) e << "min observations must be >= 0; ";
  if (!(o.max_error_px > 0)) e << "max landmark error must be > 0; ";
  const std::string message = e.str();
  if (message.empty()) return true;
  if (why) *why = message.substr(0, message.size() - 2);
  return false;
}

OccupancyMap::OccupancyMap(const OccupancyMapOptions& options) : options_(options) {
  std::string why;
  if (!ValidateOccupancyMapOptions(options_, &why)) throw std::invalid_argument("occupancy map: " + why);
  size_ = static_cast<int>(std::ceil(options_.size_mm / options_.cell_mm));
  origin_ = -0.5 * size_ * options_.cell_mm;
  const size_t n = static_cast<size_t>(size_) * size_;
  seen_.assign(n, 0);
  stood_.assign(n, 0);
  obstacle_.assign(n, 0);
  remembered_.assign(n, 0);
  felt_.assign(n, 0);
  remembered_floor_.assign(n, 0);
  floor_.assign(n, 0);
  state_.assign(n, State::kUnknown);
  obstacle_distance_.assign(n, kFar);
  unknown_distance_.assign(n, 0.f);
  unexplored_distance_.assign(n, 0.f);
  floor_distance_.assign(n, kFar);
  remembered_floor_distance_.assign(n, kFar);
  unexplored_sum_.assign(static_cast<size_t>(size_ + 1) * (size_ + 1), 0);
  for (int y = 1; y <= size_; ++y)
    for (int x = 1; x <= size_; ++x) unexplored_sum_[static_cast<size_t>(y) * (size_ + 1) + x] = x * y;
}

bool OccupancyMap::IndexOf(const Eigen::Vector2d& p, int* index) const {
  if (!std::isfinite(p.x()) || !std::isfinite(p.y())) return false;
  const double fx = (p.x() - origin_) / options_.cell_mm, fy = (p.y() - origin_) / options_.cell_mm;
  if (fx < 0 || fy < 0 || fx >= size_ || fy >= size_) return false;
  *index = IndexAt(static_cast<int>(fx), static_cast<int>(fy));
  return true;
}

Eigen::Vector2d OccupancyMap::CentreOf(int index) const {
  return {origin_ + (XOf(index) + 0.5) * options_.cell_mm, origin_ + (YOf(index) + 0.5) * options_.cell_mm};
}

void OccupancyMap::SetLandmarks(const std::vector<MapLandmark>& landmarks) {
  std::fill(obstacle_.begin(), obstacle_.end(), 0);
  std::fill(floor_.begin(), floor_.end(), 0);
  obstacle_landmarks_ = floor_landmarks_ = 0;
  // The local floor: the mean height of the near-floor landmarks (|z| <= 2.5 floor bands) in 500 mm blocks, over
  // the 3 x 3 blocks around a landmark (>= kMinLocalFloorPoints of them, else z = 0). A map whose height drifts by
  // a few cm over metres (the pose solver's, exploring) would otherwise turn the far floor into obstacles.
  constexpr double kBlockMm = 500;
  constexpr int kMinLocalFloorPoints = 8;
  const int blocks = static_cast<int>(std::ceil(options_.size_mm / kBlockMm)) + 1;
  std::vector<double> block_sum(static_cast<size_t>(blocks) * blocks, 0.0);
  std::vector<int> block_count(block_sum.size(), 0);
  auto block_of = [&](const Eigen::Vector3f& p, int* bx, int* by) {
    *bx = static_cast<int>(std::floor((p.x() - origin_) / kBlockMm));
    *by = static_cast<int>(std::floor((p.y() - origin_) / kBlockMm));
    return *bx >= 0 && *by >= 0 && *bx < blocks && *by < blocks;
  };
  auto usable = [&](const MapLandmark& l) {
    return l.position_mm.allFinite() && l.observations >= options_.min_observations &&
           l.error_px <= options_.max_error_px;
  };
  for (const MapLandmark& l : landmarks) {
    int bx, by;
    if (!usable(l) || std::abs(l.position_mm.z()) > 2.5 * options_.floor_band_mm || !block_of(l.position_mm, &bx, &by))
      continue;
    block_sum[static_cast<size_t>(by) * blocks + bx] += l.position_mm.z();
    ++block_count[static_cast<size_t>(by) * blocks + bx];
  }
  auto local_floor = [&](const Eigen::Vector3f& p) {
    int bx, by;
    if (!block_of(p, &bx, &by)) return 0.0;
    double sum = 0;
    int count = 0;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        if (bx + dx < 0 || by + dy < 0 || bx + dx >= blocks || by + dy >= blocks) continue;
        sum += block_sum[static_cast<size_t>(by + dy) * blocks + bx + dx];
        count += block_count[static_cast<size_t>(by + dy) * blocks + bx + dx];
      }
    return count >= kMinLocalFloorPoints ? sum / count : 0.0;
  };
  for (const MapLandmark& l : landmarks) {
    if (!usable(l)) continue;
    int index;
    if (!IndexOf(l.position_mm.head<2>().cast<double>(), &index)) continue;
    const double z = l.position_mm.z() - local_floor(l.position_mm);
    if (z >= options_.obstacle_min_z_mm && z <= options_.obstacle_max_z_mm) {
      if (obstacle_[index] < 255) ++obstacle_[index];
      ++obstacle_landmarks_;
    } else if (std::abs(z) <= options_.floor_band_mm) {
      floor_[index] = 1;
      const int x = XOf(index), y = YOf(index);  // the floor was visible here: the cell and its neighbours
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          if (x + dx < 0 || y + dy < 0 || x + dx >= size_ || y + dy >= size_) continue;
          uint8_t& seen = seen_[static_cast<size_t>(IndexAt(x + dx, y + dy))];
          if (!seen) {
            seen = 1;
            seen_dirty_ = true;
          }
        }
      ++floor_landmarks_;
    }
  }
  for (size_t i = 0; i < remembered_floor_.size() && any_remembered_floor_; ++i)
    if (remembered_floor_[i] && obstacle_[i]) remembered_floor_[i] = 0;  // something stands there now
  remembered_cells_ = 0;
  for (size_t i = 0; i < remembered_.size(); ++i) {
    if (!remembered_[i]) continue;
    if (floor_[i]) {
      remembered_[i] = 0;  // the floor is visible there now
    } else {
      ++remembered_cells_;
      if (!obstacle_[i]) obstacle_[i] = 1;
    }
  }
  for (size_t i = 0; i < felt_.size() && felt_cells_ > 0; ++i)
    if (felt_[i] && !obstacle_[i]) obstacle_[i] = 1;
  landmarks_dirty_ = true;
}

void OccupancyMap::MarkFelt(const Eigen::Vector2d& p) {
  int index;
  if (!IndexOf(p, &index) || felt_[index]) return;
  felt_[index] = 1;
  ++felt_cells_;
  if (!obstacle_[index]) obstacle_[index] = 1;
  landmarks_dirty_ = true;
}

bool OccupancyMap::FeltWithin(const Eigen::Vector2d& p, double radius_mm) const {
  if (felt_cells_ == 0 || !p.allFinite()) return false;
  const int reach = static_cast<int>(std::ceil(radius_mm / options_.cell_mm)) + 1;
  for (int dy = -reach; dy <= reach; ++dy)
    for (int dx = -reach; dx <= reach; ++dx) {
      int index;
      const Eigen::Vector2d q = p + options_.cell_mm * Eigen::Vector2d(dx, dy);
      if (IndexOf(q, &index) && felt_[index] && (CentreOf(index) - p).norm() <= radius_mm) return true;
    }
  return false;
}

void OccupancyMap::RememberOldMap() {
  for (size_t i = 0; i < obstacle_.size(); ++i) {
    if (obstacle_[i]) remembered_[i] = 1;
    if (floor_[i] && !obstacle_[i]) {
      remembered_floor_[i] = 1;
      any_remembered_floor_ = true;
    }
  }
  landmarks_dirty_ = true;
}

void OccupancyMap::MarkView(const Eigen::Isometry3d& world_from_camera, const CameraIntrinsics& camera) {
  if (!world_from_camera.matrix().allFinite() || !camera.IsValid()) return;
  const Eigen::Isometry3d camera_from_world = world_from_camera.inverse();
  const Eigen::Vector3d c = world_from_camera.translation();
  if (!(c.z() > 0)) return;  // a camera at or below the floor sees no floor
  const Eigen::Vector3d axis = world_from_camera.linear().col(2);
  const Eigen::Vector3d up = -world_from_camera.linear().col(1);
  const Eigen::Vector2d forward = std::hypot(axis.x(), axis.y()) > 1e-3 ? axis.head<2>() : up.head<2>();
  const double yaw = std::atan2(forward.y(), forward.x());
  const double half = 0.5 * camera.HorizontalFovRad() + 0.35;  // the floor trapezoid is wider than the FOV's wedge
  const double step = 0.5 * options_.cell_mm;
  const double angle_step = step / options_.view_range_mm;
  for (double a = yaw - half; a <= yaw + half; a += angle_step) {
    const Eigen::Vector2d dir(std::cos(a), std::sin(a));
    for (double s = step; s <= options_.view_range_mm; s += step) {
      const Eigen::Vector2d p = c.head<2>() + s * dir;
      int index;
      if (!IndexOf(p, &index)) break;
      if (obstacle_[index]) break;  // an obstacle hides the floor behind it
      double u, v;
      if (!camera.Project(camera_from_world * Eigen::Vector3d(p.x(), p.y(), 0), &u, &v) || !camera.InImage(u, v))
        continue;
      if (!seen_[index]) {
        seen_[index] = 1;
        seen_dirty_ = true;
      }
    }
  }
}

void OccupancyMap::MarkFootprint(const Eigen::Vector2d& p) {
  int centre;
  if (!IndexOf(p, &centre)) return;
  const double radius = options_.footprint_radius_mm + 0.5 * options_.cell_mm;
  const double seen_radius = radius + kBesideFootprintMm;
  const int r = static_cast<int>(std::ceil(seen_radius / options_.cell_mm));
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx) {
      const int x = XOf(centre) + dx, y = YOf(centre) + dy;
      if (x < 1 || y < 1 || x >= size_ - 1 || y >= size_ - 1) continue;
      const int index = IndexAt(x, y);
      const double d = (CentreOf(index) - p).norm();
      if (d <= radius && !stood_[index]) {
        stood_[index] = 1;
        seen_dirty_ = true;
      } else if (d <= seen_radius && !seen_[index]) {
        seen_[index] = 1;
        seen_dirty_ = true;
      }
    }
}

void OccupancyMap::Update() {
  if (!landmarks_dirty_ && !seen_dirty_) return;
  const size_t n = state_.size();
  const double cell = options_.cell_mm;
  std::vector<float> squared;
  // Distance (mm) from every cell to the nearest cell set in `sites` (kFar when none).
  auto distance_to = [&](const std::vector<uint8_t>& sites, std::vector<float>* out) {
    SquaredDistanceToSites(sites, size_, size_, &squared);
    for (size_t i = 0; i < n; ++i) (*out)[i] = squared[i] >= kFar ? kFar : std::sqrt(squared[i]) * cell;
  };
  if (landmarks_dirty_) {
    distance_to(obstacle_, &obstacle_distance_);
    if (options_.free_support_mm > 0) {
      distance_to(floor_, &floor_distance_);
      if (any_remembered_floor_) distance_to(remembered_floor_, &remembered_floor_distance_);
    }
  }
  std::vector<uint8_t> unknown(n, 0), unexplored(n, 0);
  obstacle_cells_ = free_cells_ = 0;
  for (size_t i = 0; i < n; ++i) {
    const int x = static_cast<int>(i) % size_, y = static_cast<int>(i) / size_;
    const bool border = x == 0 || y == 0 || x == size_ - 1 || y == size_ - 1;
    const bool supported = options_.free_support_mm <= 0 || floor_distance_[i] <= options_.free_support_mm;
    const bool supported_before = any_remembered_floor_ && options_.free_support_mm > 0 &&
                                  remembered_floor_distance_[i] <= options_.free_support_mm;
    if (obstacle_[i]) {
      state_[i] = State::kOccupied;
      ++obstacle_cells_;
    } else if (!border && (stood_[i] || (seen_[i] && (supported || supported_before)))) {
      state_[i] = State::kFree;
      ++free_cells_;
      if (!stood_[i] && !supported) unexplored[i] = 1;  // free by the old map's floor only
    } else {
      state_[i] = State::kUnknown;
      unknown[i] = 1;
      unexplored[i] = 1;
    }
  }
  distance_to(unknown, &unknown_distance_);
  if (any_remembered_floor_)
    distance_to(unexplored, &unexplored_distance_);
  else
    unexplored_distance_ = unknown_distance_;
  const int w = size_ + 1;
  for (int y = 0; y < size_; ++y) {
    int32_t row = 0;
    for (int x = 0; x < size_; ++x) {
      row += unexplored[static_cast<size_t>(y) * size_ + x];
      unexplored_sum_[static_cast<size_t>(y + 1) * w + x + 1] =
          unexplored_sum_[static_cast<size_t>(y) * w + x + 1] + row;
    }
  }
  landmarks_dirty_ = seen_dirty_ = false;
  ++version_;
}

double OccupancyMap::SafeObstacleDistanceMm() const {
  // A landmark lies anywhere in its cell and the robot anywhere in its own: centre distances overstate the true
  // distance by up to a cell diagonal.
  return options_.footprint_radius_mm + M_SQRT2 * options_.cell_mm;
}

bool OccupancyMap::Traversable(int index) const {
  return state_[index] == State::kFree &&
         obstacle_distance_[index] >=
             std::max(options_.footprint_radius_mm + options_.safety_margin_mm, SafeObstacleDistanceMm()) &&
         unknown_distance_[index] >= options_.footprint_radius_mm;
}

bool OccupancyMap::Passable(int index) const {
  return state_[index] == State::kFree && obstacle_distance_[index] >= SafeObstacleDistanceMm() &&
         unknown_distance_[index] >= options_.footprint_radius_mm;
}

bool OccupancyMap::TraversableAt(const Eigen::Vector2d& p) const {
  int index;
  return IndexOf(p, &index) && Traversable(index);
}

bool OccupancyMap::FootprintSafe(const Eigen::Vector2d& p) const {
  int index;
  return IndexOf(p, &index) && Passable(index);
}

int OccupancyMap::UnexploredCellsNear(int index, double radius_mm) const {
  const int r = static_cast<int>(std::round(radius_mm / options_.cell_mm));
  const int x0 = std::max(0, XOf(index) - r), y0 = std::max(0, YOf(index) - r);
  const int x1 = std::min(size_, XOf(index) + r + 1), y1 = std::min(size_, YOf(index) + r + 1);
  const int w = size_ + 1;
  auto at = [&](int x, int y) { return unexplored_sum_[static_cast<size_t>(y) * w + x]; };
  return at(x1, y1) - at(x0, y1) - at(x1, y0) + at(x0, y0);
}

}  // namespace objscan
