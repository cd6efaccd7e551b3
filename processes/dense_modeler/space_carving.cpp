#include "processes/dense_modeler/space_carving.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <unordered_map>

namespace objscan {
namespace {

const Eigen::Vector3i kFaces[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};

struct Projection {
  float u, v, z;
  bool ok;
};

// Merges the seeds into one voxel per cell (votes summed; first seed's colour and normal), indexed by VoxelKey.
// given_normals: one per voxel when seed_normals is set, else left empty.
void MergeSeeds(const std::vector<VoxelRecord>& seeds, const std::vector<Eigen::Vector3d>* seed_normals,
                std::vector<CarvedVoxel>* voxels, std::vector<Eigen::Vector3d>* given_normals,
                std::unordered_map<uint64_t, int>* index) {
  index->reserve(seeds.size() * 2);
  for (size_t si = 0; si < seeds.size(); ++si) {
    const VoxelRecord& s = seeds[si];
    auto it = index->find(VoxelKey(s.ijk));
    if (it != index->end()) {
      (*voxels)[it->second].votes += s.votes;
      continue;
    }
    index->emplace(VoxelKey(s.ijk), static_cast<int>(voxels->size()));
    CarvedVoxel c;
    c.ijk = s.ijk;
    c.votes = s.votes;
    c.bgr = s.bgr;
    voxels->push_back(c);
    if (seed_normals) given_normals->push_back((*seed_normals)[si]);
  }
}

// The views with a valid camera, a finite pose and a non-empty 8-bit image (1 or 3 channels) of the camera's size.
std::vector<const CarvingView*> UsableViews(const std::vector<CarvingView>& views_in) {
  std::vector<const CarvingView*> views;
  for (const CarvingView& v : views_in)
    if (!v.image.empty() && v.image.cols == v.camera.width && v.image.rows == v.camera.height &&
        (v.image.type() == CV_8UC3 || v.image.type() == CV_8UC1) && v.camera.IsValid() &&
        v.world_from_camera.matrix().allFinite())
      views.push_back(&v);
  return views;
}

// Indices of the alive voxels with an empty (or dead) 6-neighbour and their unit outward normals (sum of the directions
// to the empty neighbours, or given_normals[i] when given; zero for an isolated voxel).
void FindSurface(const std::vector<CarvedVoxel>& voxels, const std::vector<char>& alive,
                 const std::unordered_map<uint64_t, int>& index, const std::vector<Eigen::Vector3d>* given_normals,
                 std::vector<int>* surface, std::vector<Eigen::Vector3d>* normals) {
  auto is_alive = [&](const Eigen::Vector3i& ijk) {
    auto it = index.find(VoxelKey(ijk));
    return it != index.end() && alive[it->second];
  };
  for (size_t i = 0; i < voxels.size(); ++i) {
    if (!alive[i]) continue;
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    bool is_surface = false;
    for (const Eigen::Vector3i& f : kFaces) {
      if (!is_alive(voxels[i].ijk + f)) {
        is_surface = true;
        n += f.cast<double>();
      }
    }
    if (!is_surface) continue;
    surface->push_back(static_cast<int>(i));
    if (given_normals) n = (*given_normals)[i];
    normals->push_back(n.norm() > 0 ? n.normalized() : n);
  }
}

// Projects the surface voxel centres (world, mm) into a view: pixel position and depth (mm) per voxel in proj (ok =
// in front and inside the image), each splatted into the view's z-buffer zbuf over its footprint (width x height).
// Counts the projections done in *projections.
void SplatView(const CarvingView& view, const std::vector<Eigen::Vector3d>& centers, double voxel_size,
               const SpaceCarvingOptions& o, std::vector<float>* zbuf, std::vector<Projection>* proj,
               int64_t* projections) {
  const PinholeCamera& cam = view.camera;
  const Eigen::Isometry3d cam_from_world = view.world_from_camera.inverse();
  const Eigen::Matrix3d r = cam_from_world.linear();
  const Eigen::Vector3d t = cam_from_world.translation();
  const int w = cam.width, h = cam.height;
  const bool distorted = cam.HasDistortion();
  zbuf->assign(static_cast<size_t>(w) * h, std::numeric_limits<float>::infinity());
  const double radius_factor = o.footprint_scale * 0.87 * voxel_size * std::max(cam.fx, cam.fy);
  for (size_t s = 0; s < centers.size(); ++s) {
    Projection& p = (*proj)[s];
    p.ok = false;
    const Eigen::Vector3d xc = r * centers[s] + t;
    if (xc.z() <= 1e-6) continue;
    double u, v;
    if (distorted) {
      Eigen::Vector2d px;
      if (!cam.Project(xc, &px)) continue;
      u = px.x(), v = px.y();
    } else {
      const double iz = 1.0 / xc.z();
      v = cam.fy * xc.y() * iz + cam.cy;
      u = cam.fx * xc.x() * iz + cam.skew * xc.y() * iz + cam.cx;
    }
    ++*projections;
    const double rad = radius_factor / xc.z();
    const int u0 = std::max(0, static_cast<int>(std::lround(u - rad)));
    const int u1 = std::min(w - 1, static_cast<int>(std::lround(u + rad)));
    const int v0 = std::max(0, static_cast<int>(std::lround(v - rad)));
    const int v1 = std::min(h - 1, static_cast<int>(std::lround(v + rad)));
    if (u0 > u1 || v0 > v1) continue;
    const float z = static_cast<float>(xc.z());
    for (int y = v0; y <= v1; ++y) {
      float* row = &(*zbuf)[static_cast<size_t>(y) * w];
      for (int x = u0; x <= u1; ++x) row[x] = std::min(row[x], z);
    }
    p.u = static_cast<float>(u), p.v = static_cast<float>(v), p.z = z;
    p.ok = u >= 0 && v >= 0 && u <= w - 1 && v <= h - 1;
  }
}

// Adds the view's bilinear colour at each surface voxel it sees (projected, facing the camera when use_normals, at
// most tol mm behind the z-buffer) to acc: per voxel sum of b g r, sum of their squares, count (7 doubles).
void AccumulateViewColours(const CarvingView& view, const std::vector<Eigen::Vector3d>& centers,
                           const std::vector<Eigen::Vector3d>& normals, const std::vector<Projection>& proj,
                           const std::vector<float>& zbuf, const SpaceCarvingOptions& o, double tol,
                           std::vector<double>* acc) {
  const Eigen::Vector3d cam_center = view.world_from_camera.translation();
  const int w = view.camera.width, h = view.camera.height;
  const int ch = view.image.channels();
  for (size_t s = 0; s < centers.size(); ++s) {
    const Projection& p = proj[s];
    if (!p.ok) continue;
    if (o.use_normals && normals[s].squaredNorm() > 0) {  // isolated voxels (zero normal) face everywhere
      const Eigen::Vector3d ray = (cam_center - centers[s]).normalized();
      if (normals[s].dot(ray) <= o.min_normal_cos) continue;
    }
    const int iu = static_cast<int>(std::lround(p.u)), iv = static_cast<int>(std::lround(p.v));
    if (p.z > zbuf[static_cast<size_t>(iv) * w + iu] + tol) continue;  // occluded
    const int x0 = std::min(static_cast<int>(p.u), w - 2), y0 = std::min(static_cast<int>(p.v), h - 2);
    const double fx = p.u - x0, fy = p.v - y0;
    const uint8_t* r0 = view.image.ptr<uint8_t>(y0) + x0 * ch;
    const uint8_t* r1 = view.image.ptr<uint8_t>(y0 + 1) + x0 * ch;
    double* a = &(*acc)[s * 7];
    for (int k = 0; k < 3; ++k) {
      const int c = ch == 3 ? k : 0;
      const double val = (1 - fy) * ((1 - fx) * r0[c] + fx * r0[ch + c]) + fy * ((1 - fx) * r1[c] + fx * r1[ch + c]);
      a[k] += val;
      a[3 + k] += val * val;
    }
    a[6] += 1;
  }
}

// Gives each surface voxel its view count, mean colour and colour std-dev (grey levels) from acc and kills those
// seen by at least min_views views whose std-dev exceeds max_color_stddev. Returns how many were killed.
int64_t JudgeSurface(const std::vector<int>& surface, const std::vector<double>& acc, const SpaceCarvingOptions& o,
                     std::vector<CarvedVoxel>* voxels, std::vector<char>* alive) {
  int64_t removed = 0;
  for (size_t s = 0; s < surface.size(); ++s) {
    const double* a = &acc[s * 7];
    CarvedVoxel& vox = (*voxels)[surface[s]];
    vox.views = static_cast<int32_t>(a[6]);
    if (a[6] < 1) {
      vox.color_stddev = 0;
      continue;
    }
    double var = 0;
    for (int k = 0; k < 3; ++k) {
      const double mean = a[k] / a[6];
      var += std::max(0.0, a[3 + k] / a[6] - mean * mean);
      vox.bgr[k] = static_cast<uint8_t>(std::clamp(std::lround(mean), 0L, 255L));
    }
    vox.color_stddev = static_cast<float>(std::sqrt(var / 3.0));
    if (vox.views >= o.min_views && vox.color_stddev > o.max_color_stddev) {
      (*alive)[surface[s]] = 0;
      ++removed;
    }
  }
  return removed;
}

// The alive voxels sorted by (k, j, i).
std::vector<CarvedVoxel> SortedAlive(const std::vector<CarvedVoxel>& voxels, const std::vector<char>& alive) {
  std::vector<CarvedVoxel> out;
  out.reserve(voxels.size());
  for (size_t i = 0; i < voxels.size(); ++i)
    if (alive[i]) out.push_back(voxels[i]);
  std::sort(out.begin(), out.end(), [](const CarvedVoxel& x, const CarvedVoxel& y) {
    if (x.ijk.z() != y.ijk.z()) return x.ijk.z() < y.ijk.z();
    if (x.ijk.y() != y.ijk.y()) return x.ijk.y() < y.ijk.y();
    return x.ijk.x() < y.ijk.x();
  });
  return out;
}

}  // namespace

bool ValidateSpaceCarvingOptions(const SpaceCarvingOptions& o, std::string* why) {
  std::ostringstream e;
  if (!(o.max_color_stddev > 0)) e << "max color stddev must be > 0; ";
  if (o.min_views < 2) e << "min views must be >= 2; ";
  if (o.max_iterations < 1) e << "max iterations must be >= 1; ";
  if (!(o.min_removed_fraction >= 0 && o.min_removed_fraction < 1)) e << "min removed fraction must be in [0, 1); ";
  if (!(o.depth_tolerance_voxels > 0)) e << "depth tolerance must be > 0; ";
  if (!(o.footprint_scale > 0)) e << "footprint scale must be > 0; ";
  if (!(o.min_normal_cos >= -1 && o.min_normal_cos < 1)) e << "min normal cos must be in [-1, 1); ";
  const std::string msg = e.str();
  if (msg.empty()) return true;
  if (why) *why = msg.substr(0, msg.size() - 2);
  return false;
}

std::vector<CarvedVoxel> CarveVoxels(const std::vector<VoxelRecord>& seeds, double voxel_size,
                                     const std::vector<CarvingView>& views_in, const SpaceCarvingOptions& o,
                                     SpaceCarvingStats* stats_out, const std::vector<Eigen::Vector3d>* seed_normals) {
  SpaceCarvingStats stats;
  if (seed_normals && seed_normals->size() != seeds.size()) seed_normals = nullptr;
  std::vector<CarvedVoxel> voxels;
  std::vector<Eigen::Vector3d> given_normals;
  std::unordered_map<uint64_t, int> index;
  MergeSeeds(seeds, seed_normals, &voxels, &given_normals, &index);
  stats.seeds = static_cast<int64_t>(voxels.size());
  if (!(voxel_size > 0) || !ValidateSpaceCarvingOptions(o, nullptr)) {
    stats.kept = stats.seeds;
    if (stats_out) *stats_out = stats;
    return voxels;
  }
  const std::vector<const CarvingView*> views = UsableViews(views_in);
  std::vector<char> alive(voxels.size(), 1);

  const double tol = o.depth_tolerance_voxels * voxel_size;
  std::vector<float> zbuf;
  std::vector<Projection> proj;
  for (int iter = 0; iter < o.max_iterations; ++iter) {
    // Surface voxels and their outward normals.
    std::vector<int> surface;
    std::vector<Eigen::Vector3d> normals;
    FindSurface(voxels, alive, index, seed_normals ? &given_normals : nullptr, &surface, &normals);
    const size_t ns = surface.size();
    std::vector<double> acc(ns * 7, 0.0);  // sum b g r, sum of squares b g r, count
    proj.resize(ns);
    std::vector<Eigen::Vector3d> centers(ns);
    for (size_t s = 0; s < ns; ++s)
      centers[s] = (voxels[surface[s]].ijk.cast<double>() + Eigen::Vector3d::Constant(0.5)) * voxel_size;

    for (const CarvingView* view : views) {
      SplatView(*view, centers, voxel_size, o, &zbuf, &proj, &stats.projections);
      AccumulateViewColours(*view, centers, normals, proj, zbuf, o, tol, &acc);
    }
    const int64_t removed = JudgeSurface(surface, acc, o, &voxels, &alive);
    stats.iterations = iter + 1;
    stats.removed_per_iteration.push_back(removed);
    stats.removed += removed;
    if (removed == 0 || removed < o.min_removed_fraction * static_cast<double>(stats.seeds)) break;
  }
  std::vector<CarvedVoxel> out = SortedAlive(voxels, alive);
  stats.kept = static_cast<int64_t>(out.size());
  if (stats_out) *stats_out = stats;
  return out;
}

}  // namespace objscan
