#include "processes/dense_modeler/dense_model.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <unordered_map>

#include "common/geometry.h"
#include "common/point_grid.h"
#include "processes/dense_modeler/export.h"

namespace objscan {

bool ValidateDenseModelOptions(const DenseModelOptions& o, std::string* why) {
  std::ostringstream e;
  std::string w;
  if (!ValidateAffineDenseOptions(o.dense, &w)) e << w << "; ";
  if (!ValidatePairMatchOptions(o.pair_matches, &w)) e << w << "; ";
  if (!ValidateVoxelVoteOptions(o.votes, &w)) e << w << "; ";
  if (!ValidateSpaceCarvingOptions(o.carving, &w)) e << w << "; ";
  if (o.vote_threshold < 1) e << "vote threshold must be >= 1; ";
  if (!(o.floor_band_mm >= 0)) e << "floor band must be >= 0 mm; ";
  if (!(o.floor_band_normal_deg > 0 && o.floor_band_normal_deg < 90)) e << "floor band normal must be in (0, 90) deg; ";
  if (!(o.crevice_band_mm >= 0)) e << "crevice band must be >= 0 mm; ";
  if (!(o.crevice_normal_deg > 0 && o.crevice_normal_deg < 90)) e << "crevice normal must be in (0, 90) deg; ";
  if (!ValidateRidgeOptions(o.ridge, &w)) e << w << "; ";
  if (!ValidateMeshVisibilityOptions(o.visibility, &w)) e << w << "; ";
  if (!ValidateWeakRefitOptions(o.weak_refit, &w)) e << w << "; ";
  const std::string msg = e.str();
  if (msg.empty()) return true;
  if (why) *why = msg.substr(0, msg.size() - 2);
  return false;
}

std::vector<PointMatch> MatchTracks(const TrackFrame& a, const TrackFrame& b) {
  std::unordered_map<int64_t, const TrackedFeature*> by_id;
  by_id.reserve(b.features.size() * 2);
  for (const TrackedFeature& f : b.features) by_id.emplace(f.id, &f);
  std::vector<PointMatch> out;
  for (const TrackedFeature& f : a.features) {
    auto it = by_id.find(f.id);
    if (it == by_id.end()) continue;
    out.push_back({Eigen::Vector2d(f.u, f.v), Eigen::Vector2d(it->second->u, it->second->v)});
  }
  return out;
}

double MedianLandmarkReprojectionPx(const PinholeCamera& camera, const Eigen::Isometry3d& world_from_camera,
                                    const TrackFrame& frame,
                                    const std::unordered_map<int64_t, Eigen::Vector3d>& landmarks, int* count) {
  const Eigen::Isometry3d camera_from_world = world_from_camera.inverse();
  std::vector<double> errors;
  for (const TrackedFeature& f : frame.features) {
    auto it = landmarks.find(f.id);
    if (it == landmarks.end()) continue;
    Eigen::Vector2d uv;
    const Eigen::Vector3d pc = camera_from_world * it->second;
    if (pc.z() > 0 && camera.Project(pc, &uv))
      errors.push_back((uv - Eigen::Vector2d(f.u, f.v)).norm());
    else
      errors.push_back(std::numeric_limits<double>::infinity());
  }
  if (count) *count = static_cast<int>(errors.size());
  if (errors.empty()) return 0.0;
  const size_t mid = errors.size() / 2;
  std::nth_element(errors.begin(), errors.begin() + static_cast<std::ptrdiff_t>(mid), errors.end());
  return errors[mid];
}

FinalModel BuildFinalModel(const VoxelVoteGrid& grid, const std::vector<CarvingView>& views, const DenseModelOptions& o,
                           const RegionOfInterest& region) {
  FinalModel model;
  using Clock = std::chrono::steady_clock;
  auto since = [](Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); };
  Clock::time_point t0 = Clock::now();
  std::vector<VoxelRecord> seeds = grid.Extract(o.vote_threshold);
  {
    std::vector<VoxelRecord> kept;
    for (const VoxelRecord& r : seeds)
      if (region.Contains(grid.CenterOf(r.ijk))) kept.push_back(r);
    seeds.swap(kept);
  }
  model.seeds = static_cast<int64_t>(seeds.size());
  std::vector<SurfaceVoxel> surface = ExtractVoteRidge(grid, seeds, o.ridge, &model.ridge);
  if (region.valid && region.has_floor && (o.floor_band_mm > 0 || o.crevice_band_mm > 0)) {
    // Floor a few mm above the fitted plane (its points are biased or the plane is) faces up; walls do not. Under
    // an overhang, surface facing down just above the floor is the crevice (see crevice_band_mm).
    const double min_up_cos = std::cos(o.floor_band_normal_deg * kDegToRad);
    const double max_down_cos = -std::sin(o.crevice_normal_deg * kDegToRad);
    std::vector<SurfaceVoxel> kept;
    kept.reserve(surface.size());
    for (const SurfaceVoxel& s : surface) {
      const double height = region.HeightAboveFloor(s.point_in_world), up = s.normal.dot(region.floor.normal);
      if (height < o.floor_band_mm && up >= min_up_cos)
        ++model.floor_band_dropped;
      else if (height < o.crevice_band_mm && up <= max_down_cos)
        ++model.crevice_band_dropped;
      else
        kept.push_back(s);
    }
    surface.swap(kept);
  }
  seeds.clear();
  std::vector<Eigen::Vector3d> normals;
  for (const SurfaceVoxel& s : surface) {
    seeds.push_back(s.voxel);
    normals.push_back(s.normal);
  }
  model.times.surface_s = since(t0);
  t0 = Clock::now();
  if (o.carve) {
    model.voxels = CarveVoxels(seeds, grid.voxel_size(), views, o.carving, &model.carving, &normals);
  } else {
    for (const VoxelRecord& r : seeds) {
      CarvedVoxel c;
      c.ijk = r.ijk;
      c.votes = r.votes;
      c.bgr = r.bgr;
      model.voxels.push_back(c);
    }
    model.carving.seeds = model.carving.kept = static_cast<int64_t>(seeds.size());
  }
  model.times.carving_s = since(t0);
  t0 = Clock::now();
  // Mesh through the surface points of the voxels that survived carving, coloured as carved.
  std::unordered_map<uint64_t, const CarvedVoxel*> alive;
  alive.reserve(model.voxels.size() * 2);
  for (const CarvedVoxel& v : model.voxels) alive.emplace(VoxelKey(v.ijk), &v);
  std::vector<SurfaceVoxel> kept;
  for (SurfaceVoxel& s : surface) {
    auto it = alive.find(VoxelKey(s.voxel.ijk));
    if (it == alive.end()) continue;
    s.voxel.bgr = it->second->bgr;
    kept.push_back(s);
  }
  model.mesh = MeshFromSurfacePoints(
      SharpenCreases(
          SmoothSurfacePoints(kept, grid.voxel_size(), o.ridge.smoothing_radius, o.ridge.smoothing_min_normal_cos),
          grid.voxel_size(), o.ridge.creases, &model.ridge.crease_points_moved),
      grid.voxel_size());
  model.times.meshing_s = since(t0);
  t0 = Clock::now();
  // Sheets inside the object, under the surface other pairs built, are hidden from most views.
  model.visibility = RemoveOccludedMeshParts(&model.mesh, views, o.visibility);
  model.times.visibility_s = since(t0);
  t0 = Clock::now();
  // The rims of holes bend off the surface: curled ones by up to max_rings rings, then all by border_rings.
  model.ridge.curled_triangles_dropped = TrimCurledBorders(&model.mesh, o.ridge.curled_borders);
  model.ridge.border_triangles_dropped = TrimMeshBorder(&model.mesh, o.ridge.border_rings);
  // Carving can split pieces off the ridge: those far smaller than the object are stray surface too.
  model.ridge.mesh_triangles_dropped = RemoveSmallMeshPieces(&model.mesh, o.ridge.min_component_fraction);
  // Where few points voted (one pair's biased points, the shadowed floor junction) the surface around decides.
  model.weak_refit = RefitWeakMeshVertices(&model.mesh, model.voxels, grid.voxel_size(), o.weak_refit);
  // The voxel model (model_voxels.ply, model.bt, the final VOXEL_MAP) is the surface the mesh kept: voxels with
  // no mesh vertex within 1.5 voxels went with their mesh part (hidden, on a curled rim or a border ring, or in a
  // small piece).
  std::vector<Eigen::Vector3d> vertices;
  vertices.reserve(model.mesh.vertices.size());
  for (const Eigen::Vector3f& v : model.mesh.vertices) vertices.push_back(v.cast<double>());
  const double reach = 1.5 * grid.voxel_size();
  const PointGrid near_mesh(vertices, reach);
  std::vector<CarvedVoxel> supported;
  supported.reserve(model.voxels.size());
  for (const CarvedVoxel& v : model.voxels) {
    if (near_mesh.Nearest(grid.CenterOf(v.ijk), 1) <= reach)  // cells of size reach: one ring covers it
      supported.push_back(v);
    else
      ++model.voxels_without_mesh;
  }
  model.voxels.swap(supported);
  model.times.clean_up_s = since(t0);
  if (!model.voxels.empty()) {
    Eigen::Vector3i lo = model.voxels[0].ijk, hi = lo;
    for (const CarvedVoxel& v : model.voxels) {
      lo = lo.cwiseMin(v.ijk);
      hi = hi.cwiseMax(v.ijk);
    }
    model.bbox_min = lo.cast<double>() * grid.voxel_size();
    model.bbox_max = (hi.cast<double>() + Eigen::Vector3d::Ones()) * grid.voxel_size();
  }
  return model;
}

bool WriteModelFiles(const std::string& dir, const FinalModel& model, double voxel_size, ScaleSource scale,
                     ModelPaths* paths, std::string* error) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    if (error) *error = "cannot create " + dir + ": " + ec.message();
    return false;
  }
  ModelPaths p;
  p.voxels_ply = (std::filesystem::path(dir) / "model_voxels.ply").string();
  p.mesh_ply = (std::filesystem::path(dir) / "model_mesh.ply").string();
  p.octomap = (std::filesystem::path(dir) / "model.bt").string();
  if (!WriteVoxelPly(p.voxels_ply, model.voxels, voxel_size, scale, error)) return false;
  if (!WriteMeshPly(p.mesh_ply, model.mesh, scale, error)) return false;
  if (!WriteOctomap(p.octomap, model.voxels, voxel_size, error)) return false;
  if (paths) *paths = p;
  return true;
}

CarvingView MakeCarvingView(const PinholeCamera& camera, const Eigen::Isometry3d& world_from_camera,
                            const cv::Mat& image, int downsample) {
  CarvingView v;
  v.world_from_camera = world_from_camera;
  v.camera = camera;
  if (downsample <= 1) {
    v.image = image.clone();
    return v;
  }
  const int w = image.cols / downsample, h = image.rows / downsample;
  cv::resize(image(cv::Rect(0, 0, w * downsample, h * downsample)), v.image, cv::Size(w, h), 0, 0, cv::INTER_AREA);
  const double s = 1.0 / downsample;
  v.camera.width = w;
  v.camera.height = h;
  v.camera.fx *= s;
  v.camera.fy *= s;
  v.camera.skew *= s;
  v.camera.cx = (camera.cx + 0.5) * s - 0.5;
  v.camera.cy = (camera.cy + 0.5) * s - 0.5;
  return v;
}

}  // namespace objscan
