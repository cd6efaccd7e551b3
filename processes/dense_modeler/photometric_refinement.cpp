#include "processes/dense_modeler/photometric_refinement.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <unordered_map>

#include "common/point_grid.h"
#include "processes/dense_modeler/affine_dense.h"
#include "processes/dense_modeler/mesh_visibility.h"
#include "processes/dense_modeler/voxel_votes.h"

namespace objscan {

bool ValidatePhotometricRefinementOptions(const PhotometricRefinementOptions& o, std::string* why) {
  std::ostringstream e;
  if (o.max_views < 2) e << "refinement max views must be >= 2; ";
  if (!(o.min_facing_cos >= -1 && o.min_facing_cos < 1)) e << "refinement min facing cos must be in [-1, 1); ";
  if (!(o.depth_tolerance_mm > 0)) e << "refinement depth tolerance must be > 0 mm; ";
  if (o.views_per_sample < 2) e << "refinement views per sample must be >= 2; ";
  if (o.min_views < 2) e << "refinement min views must be >= 2; ";
  if (!(o.sample_spacing_mm > 0)) e << "refinement sample spacing must be > 0 mm; ";
  if (!(o.search_mm > 0)) e << "refinement search must be > 0 mm; ";
  if (!(o.step_mm > 0 && o.step_mm <= o.search_mm)) e << "refinement step must be in (0, search] mm; ";
  if (o.patch_half < 1 || o.patch_half > 8) e << "refinement patch half size must be in [1, 8]; ";
  if (!(o.patch_spacing_mm > 0)) e << "refinement patch spacing must be > 0 mm; ";
  if (!(o.min_score >= -1 && o.min_score <= 1)) e << "refinement min score must be in [-1, 1]; ";
  if (!(o.min_gain >= 0)) e << "refinement min gain must be >= 0; ";
  if (!(o.min_patch_stddev >= 0)) e << "refinement min patch std-dev must be >= 0; ";
  if (!(o.smoothing_radius_mm > 0)) e << "refinement smoothing radius must be > 0 mm; ";
  if (!(o.min_normal_cos >= -1 && o.min_normal_cos < 1)) e << "refinement min normal cos must be in [-1, 1); ";
  if (o.min_neighbour_samples < 1) e << "refinement min neighbour samples must be >= 1; ";
  const std::string msg = e.str();
  if (why) *why = msg.empty() ? msg : msg.substr(0, msg.size() - 2);
  return msg.empty();
}

namespace {

struct GrayView {
  const PinholeCamera* camera = nullptr;
  Eigen::Isometry3d camera_from_world = Eigen::Isometry3d::Identity();
  cv::Mat gray;  // CV_8UC1, camera's size
};

// Bilinear gray value at (u, v); the caller keeps (u, v) inside [0, w - 1) x [0, h - 1).
inline float Bilinear(const cv::Mat& g, float u, float v) {
  const int x = static_cast<int>(u), y = static_cast<int>(v);
  const float fx = u - x, fy = v - y;
  const uint8_t* r0 = g.ptr<uint8_t>(y) + x;
  const uint8_t* r1 = r0 + g.step[0];
  const float top = r0[0] + fx * (r0[1] - r0[0]);
  const float bottom = r1[0] + fx * (r1[1] - r1[0]);
  return top + fy * (bottom - top);
}

struct SampleResult {
  bool kept = false;
  double offset_mm = 0;
  double score = 0;
};

}  // namespace

PhotometricRefinementStats RefineMeshPhotometric(TriangleMesh* mesh, const std::vector<CarvingView>& views,
                                                 const PhotometricRefinementOptions& o) {
  PhotometricRefinementStats stats;
  if (!o.enabled || mesh->vertices.empty() || views.size() < 2 || !ValidatePhotometricRefinementOptions(o, nullptr))
    return stats;
  const size_t n_vertices = mesh->vertices.size();
  const std::vector<Eigen::Vector3f> normals = VertexNormals(*mesh);

  // Sample vertices: the first vertex of every sample_spacing_mm cell that has a normal.
  std::vector<char> is_sample(n_vertices, 0);
  {
    std::unordered_map<uint64_t, char> taken;
    const double inv = 1.0 / o.sample_spacing_mm;
    for (size_t i = 0; i < n_vertices; ++i) {
      if (normals[i].squaredNorm() == 0) continue;
      const Eigen::Vector3i cell = (mesh->vertices[i].cast<double>() * inv).array().floor().cast<int>();
      if (taken.emplace(VoxelKey(cell), 1).second) {
        is_sample[i] = 1;
        ++stats.samples;
      }
    }
  }
  MeshVisibilityOptions vis;
  vis.min_facing_cos = o.min_facing_cos;
  vis.depth_tolerance_mm = o.depth_tolerance_mm;
  vis.max_views = o.max_views;
  vis.min_seen_views = 0;
  vis.min_seen_fraction = 0;
  const std::vector<std::vector<int>> seeing = SeeingViews(*mesh, views, vis, &is_sample, &stats.views);

  // Gray copies of the views some sample sees (the camera as stored).
  std::vector<char> used(views.size(), 0);
  for (const std::vector<int>& list : seeing)
    for (int vi : list) used[static_cast<size_t>(vi)] = 1;
  std::vector<GrayView> gray(views.size());
  for (size_t vi = 0; vi < views.size(); ++vi) {
    const CarvingView& v = views[vi];
    if (!used[vi] || !v.camera.IsValid() || v.image.empty() || v.image.cols != v.camera.width ||
        v.image.rows != v.camera.height || v.image.depth() != CV_8U)
      continue;
    if (v.image.channels() != 1 && v.image.channels() != 3) continue;
    GrayView& g = gray[vi];
    g.camera = &v.camera;
    g.camera_from_world = v.world_from_camera.inverse();
    g.gray = Gray8(v.image);
  }

  const int n_steps = static_cast<int>(std::floor(o.search_mm / o.step_mm + 1e-9));
  const int n_offsets = 2 * n_steps + 1;
  const int side = 2 * o.patch_half + 1, m = side * side;
  std::vector<SampleResult> results(n_vertices);
  std::vector<int> picked;
  std::vector<Eigen::Vector2f> origin, du, dv;  // per picked view and offset
  std::vector<float> sum(static_cast<size_t>(m)), patch(static_cast<size_t>(m));
  std::vector<double> score(static_cast<size_t>(n_offsets));
  std::vector<float> min_stddev(static_cast<size_t>(n_offsets));
  const auto project = [](const GrayView& g, const Eigen::Vector3d& p, Eigen::Vector2f* uv) {
    Eigen::Vector2d q;
    const Eigen::Vector3d pc = g.camera_from_world * p;
    if (!(pc.z() > 0) || !g.camera->Project(pc, &q)) return false;
    *uv = q.cast<float>();
    return true;
  };
  for (size_t i = 0; i < n_vertices; ++i) {
    if (!is_sample[i]) continue;
    std::vector<int> usable;
    for (int vi : seeing[i])
      if (gray[static_cast<size_t>(vi)].camera) usable.push_back(vi);
    if (static_cast<int>(usable.size()) < o.min_views) continue;
    const Eigen::Vector3d p = mesh->vertices[i].cast<double>(), n = normals[i].cast<double>().normalized();
    const Eigen::Vector3d t1 = n.unitOrthogonal(), t2 = n.cross(t1);
    // Up to views_per_sample views, evenly spread over the seeing ones; each must hold the whole patch at every
    // offset (its corners at both ends of the search).
    picked.clear();
    const int k_max = std::min<int>(o.views_per_sample, static_cast<int>(usable.size()));
    for (int k = 0; k < k_max; ++k) {
      const int vi = usable[static_cast<size_t>(
          k_max == 1 ? 0 : std::lround(static_cast<double>(k) * (usable.size() - 1) / (k_max - 1)))];
      if (!picked.empty() && picked.back() == vi) continue;
      picked.push_back(vi);
    }
    origin.assign(picked.size() * n_offsets, Eigen::Vector2f::Zero());
    du = origin;
    dv = origin;
    std::vector<char> view_ok(picked.size(), 1);
    for (size_t k = 0; k < picked.size(); ++k) {
      const GrayView& g = gray[static_cast<size_t>(picked[k])];
      for (int s = 0; s < n_offsets && view_ok[k]; ++s) {
        const Eigen::Vector3d c = p + ((s - n_steps) * o.step_mm) * n;
        Eigen::Vector2f a, b, d;
        if (!project(g, c, &a) || !project(g, c + o.patch_spacing_mm * t1, &b) ||
            !project(g, c + o.patch_spacing_mm * t2, &d)) {
          view_ok[k] = 0;
          break;
        }
        const size_t idx = k * n_offsets + s;
        origin[idx] = a;
        du[idx] = b - a;
        dv[idx] = d - a;
        // The patch's corners (affine approximation of the projection over the small patch).
        for (int cy = -1; cy <= 1; cy += 2)
          for (int cx = -1; cx <= 1; cx += 2) {
            const Eigen::Vector2f q = a + (cx * o.patch_half) * du[idx] + (cy * o.patch_half) * dv[idx];
            if (!(q.x() >= 0 && q.y() >= 0 && q.x() < g.camera->width - 1 && q.y() < g.camera->height - 1))
              view_ok[k] = 0;
          }
      }
    }
    int n_views = 0;
    for (char ok : view_ok) n_views += ok;
    if (n_views < o.min_views) continue;
    ++stats.samples_scored;
    for (int s = 0; s < n_offsets; ++s) {
      std::fill(sum.begin(), sum.end(), 0.0f);
      float lowest_stddev = 1e30f;
      for (size_t k = 0; k < picked.size(); ++k) {
        if (!view_ok[k]) continue;
        const GrayView& g = gray[static_cast<size_t>(picked[k])];
        const size_t idx = k * n_offsets + s;
        double mean = 0;
        int j = 0;
        for (int y = -o.patch_half; y <= o.patch_half; ++y)
          for (int x = -o.patch_half; x <= o.patch_half; ++x, ++j) {
            const Eigen::Vector2f q = origin[idx] + static_cast<float>(x) * du[idx] + static_cast<float>(y) * dv[idx];
            patch[static_cast<size_t>(j)] = Bilinear(g.gray, q.x(), q.y());
            mean += patch[static_cast<size_t>(j)];
          }
        mean /= m;
        double var = 0;
        for (float& v : patch) {
          v -= static_cast<float>(mean);
          var += static_cast<double>(v) * v;
        }
        const double stddev = std::sqrt(var / m);
        lowest_stddev = std::min(lowest_stddev, static_cast<float>(stddev));
        const float inv = var > 1e-9 ? static_cast<float>(1.0 / std::sqrt(var)) : 0.0f;
        for (int q = 0; q < m; ++q) sum[static_cast<size_t>(q)] += patch[static_cast<size_t>(q)] * inv;
      }
      // Mean NCC over all pairs: |sum of unit vectors|^2 = K + 2 sum_{pairs} NCC.
      double s2 = 0;
      for (float v : sum) s2 += static_cast<double>(v) * v;
      score[static_cast<size_t>(s)] = (s2 - n_views) / (static_cast<double>(n_views) * (n_views - 1));
      min_stddev[static_cast<size_t>(s)] = lowest_stddev;
    }
    const int best = static_cast<int>(std::max_element(score.begin(), score.end()) - score.begin());
    if (best == 0 || best == n_offsets - 1) continue;  // at an end: the surface lies beyond the search
    const double s_best = score[static_cast<size_t>(best)];
    if (s_best < o.min_score || min_stddev[static_cast<size_t>(best)] < o.min_patch_stddev) continue;
    const double sm = score[static_cast<size_t>(best - 1)], sp = score[static_cast<size_t>(best + 1)];
    const double denom = sm - 2 * s_best + sp;
    const double frac = denom < 0 ? std::clamp(0.5 * (sm - sp) / denom, -0.5, 0.5) : 0.0;
    const double offset = (best - n_steps + frac) * o.step_mm;
    if (std::abs(offset) > o.step_mm && s_best - score[static_cast<size_t>(n_steps)] < o.min_gain) continue;
    results[i] = {true, offset, s_best};
    ++stats.samples_kept;
  }

  // Every vertex: the weighted median of the kept samples' offsets around it.
  std::vector<Eigen::Vector3d> kept_points;
  std::vector<size_t> kept_index;
  for (size_t i = 0; i < n_vertices; ++i)
    if (results[i].kept) {
      kept_points.push_back(mesh->vertices[i].cast<double>());
      kept_index.push_back(i);
    }
  if (kept_points.empty()) return stats;
  const PointGrid grid(kept_points, o.smoothing_radius_mm);
  const double inv_two_sigma2 = 1.0 / (2.0 * std::pow(0.5 * o.smoothing_radius_mm, 2));
  std::vector<std::pair<double, double>> votes;  // (offset, weight)
  std::vector<float> moves(n_vertices, 0.0f);
  double sum_abs = 0;
  for (size_t i = 0; i < n_vertices; ++i) {
    if (normals[i].squaredNorm() == 0) continue;
    const Eigen::Vector3d p = mesh->vertices[i].cast<double>();
    votes.clear();
    grid.ForEachWithin(p, o.smoothing_radius_mm, [&](int j) {
      const size_t s = kept_index[static_cast<size_t>(j)];
      if (normals[s].dot(normals[i]) < o.min_normal_cos) return;
      const double d2 = (kept_points[static_cast<size_t>(j)] - p).squaredNorm();
      votes.emplace_back(results[s].offset_mm, results[s].score * std::exp(-d2 * inv_two_sigma2));
    });
    if (static_cast<int>(votes.size()) < o.min_neighbour_samples) continue;
    std::sort(votes.begin(), votes.end());
    double total = 0;
    for (const auto& v : votes) total += v.second;
    double acc = 0, median = votes.back().first;
    for (const auto& v : votes) {
      acc += v.second;
      if (acc >= 0.5 * total) {
        median = v.first;
        break;
      }
    }
    moves[i] = static_cast<float>(median);
  }
  for (size_t i = 0; i < n_vertices; ++i) {
    if (moves[i] == 0.0f) continue;
    mesh->vertices[i] += moves[i] * normals[i];
    ++stats.vertices_moved;
    sum_abs += std::abs(moves[i]);
    stats.max_abs_offset_mm = std::max(stats.max_abs_offset_mm, static_cast<double>(std::abs(moves[i])));
  }
  if (stats.vertices_moved > 0) stats.mean_abs_offset_mm = sum_abs / stats.vertices_moved;
  return stats;
}

}  // namespace objscan
