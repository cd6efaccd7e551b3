// objscan_evaluate: scores results against ground truth.
//   objscan_evaluate trajectory ESTIMATE.txt TRUTH.txt [--no-scale] [--max-dt S]
//       TUM files; prints matched poses, ATE RMSE / max (file units, objscan: mm), rotation error (deg), scale.
//   objscan_evaluate surface MODEL.ply TRUTH.ply [--threshold D] [--min-z Z] [--align EST.txt TRUTH.txt]
//       accuracy (model -> whole truth surface) p50/p90/max and completeness (truth points within D of the model);
//       --min-z drops truth points below Z from the completeness set (e.g. the part hidden against the floor);
//       --align first maps the model with the Sim(3) that aligns the estimated trajectory to the true one;
//       --visible-from POSES.txt keeps only truth points seen by >= --min-views (2) of those cameras in the
//       completeness set (--intrinsics fx,fy,cx,cy,w,h; default the sim's 800,800,319.5,239.5,640,480), so
//       completeness is measured on the visible surface (needs truth normals); a truth point hidden from a camera by
//       other truth points (z-buffer, see VisibleSurfacePoints) does not count as seen by it (--no-occlusion: facing
//       and in the image is enough, the figure before 1 Dec night; exact for convex objects only). Accuracy is
//       always against the whole true surface (a model point on a part no camera saw is still on the surface);
//       visible_accuracy_* repeat it against the completeness set only (the stricter figure the tests used before 29
//       Nov).
//       --truth-mesh MESH.ply (the surface the simulator rendered, robot_sim's target_mesh.ply): accuracy_* become
//       the exact distances of the model points to that surface; the distances to the nearest truth sample, which
//       carry the samples' spacing (1 random sample per mm^2: p90 0.86 mm for a perfect model), are then printed as
//       sample_accuracy_*.
//       --write-aligned FILE writes the model points as scored (after --align; "x y z" per line, truth frame) and
//       --write-visible FILE the completeness set, e.g. to see where the errors and the holes are;
//       --write-errors FILE writes "x y z distance" per model point (truth frame, the accuracy_* distances).
//   objscan_evaluate target TARGET.json TRUTH.json [--align EST.txt TRUTH.txt]
//       the object finder's box (target.json: centre_mm, size_mm, state) against the true one (robot_sim's
//       ground_truth/sim_outcome.json: center_mm, size_mm of the target), the estimate first mapped by the Sim(3)
//       that aligns the estimated trajectory to the true one; prints center_error_mm (3-D), center_error_xy_mm and
//       the extents' errors (larger and smaller floor extent, height).
// Output is one "key value" pair per line (easy to grep in tests and scripts).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "common/options.h"
#include "tools/evaluate/evaluation.h"

namespace {
int Fail(const std::string& message) {
  std::fprintf(stderr, "error: %s\n", message.c_str());
  return 1;
}

// The Sim(3) that aligns the estimated trajectory (TUM file) to the true one (--align of surface and target).
bool TruthFromEstimate(const std::string& estimated_path, const std::string& truth_path, objscan::Sim3* out,
                       std::string* error) {
  std::vector<objscan::StampedPose> est, tru;
  if (!objscan::ReadTumTrajectory(estimated_path, &est, error) || !objscan::ReadTumTrajectory(truth_path, &tru, error))
    return false;
  objscan::TrajectoryEvaluation e;
  if (!objscan::EvaluateTumTrajectories(est, tru, true, 0.005, &e, error)) return false;
  *out = e.error.alignment;
  return true;
}

// "x y z" per point, or "x y z value" with values (one per point).
bool WriteXyz(const std::string& path, const std::vector<Eigen::Vector3d>& points, std::string* error,
              const std::vector<double>* values = nullptr) {
  std::ofstream out(path);
  for (size_t i = 0; i < points.size(); ++i) {
    out << points[i].x() << ' ' << points[i].y() << ' ' << points[i].z();
    if (values) out << ' ' << (*values)[i];
    out << '\n';
  }
  if (!out) *error = "cannot write " + path;
  return static_cast<bool>(out);
}
}  // namespace


namespace {
using namespace objscan;

// objscan_evaluate trajectory EST TRUTH [options] (argv[2], argv[3]; options from argv[4]): ATE after Sim(3) (or SE(3)).
int EvaluateTrajectoryCommand(int argc, char** argv) {
  std::string error;
  bool with_scale = true;
  double max_dt = 0.005;
  for (int i = 4; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--no-scale")
      with_scale = false;
    else if (a == "--max-dt" && i + 1 < argc) {
      if (!ParseFiniteNumber(argv[++i], &max_dt) || max_dt < 0) return Fail("--max-dt wants seconds >= 0, got " + std::string(argv[i]));
    }
    else
      return Fail("unknown option " + a);
  }
  std::vector<StampedPose> est, truth;
  if (!ReadTumTrajectory(argv[2], &est, &error) || !ReadTumTrajectory(argv[3], &truth, &error)) return Fail(error);
  TrajectoryEvaluation e;
  if (!EvaluateTumTrajectories(est, truth, with_scale, max_dt, &e, &error)) return Fail(error);
  std::printf(
      "matched %d\nestimated %d\ntruth %d\nregistered_fraction %.4f\nate_rmse %.4f\nate_max %.4f\n"
      "rotation_mean_deg %.4f\nrotation_max_deg %.4f\nscale %.6f\n",
      e.num_matched, e.num_estimated, e.num_truth, e.registered_fraction, e.error.ate_rmse, e.error.ate_max,
      e.error.rotation_mean_rad * 180 / M_PI, e.error.rotation_max_rad * 180 / M_PI, e.error.scale);
  return 0;

}

// objscan_evaluate surface MODEL.ply TRUTH.ply [options]: accuracy and completeness against the truth's samples (or
// its mesh), optionally aligned by the trajectories and restricted to what the views saw.
int EvaluateSurfaceCommand(int argc, char** argv) {
  std::string error;
  double threshold = 2.0, min_z = -1e300;
  std::string align_est, align_truth, visible_from, write_aligned, write_visible, write_errors, truth_mesh;
  ViewIntrinsics intrinsics;
  int min_views = 2;
  bool occlusion = true;
  for (int i = 4; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--threshold" && i + 1 < argc) {
      if (!ParseFiniteNumber(argv[++i], &threshold) || !(threshold > 0))
        return Fail("--threshold wants a distance in mm > 0, got " + std::string(argv[i]));
    } else if (a == "--min-z" && i + 1 < argc) {
      if (!ParseFiniteNumber(argv[++i], &min_z)) return Fail("--min-z wants a height in mm, got " + std::string(argv[i]));
    }
    else if (a == "--visible-from" && i + 1 < argc)
      visible_from = argv[++i];
    else if (a == "--min-views" && i + 1 < argc) {
      double v = 0;
      if (!ParseFiniteNumber(argv[++i], &v) || v < 1 || v != std::floor(v) || v > 1e6)
        return Fail("--min-views wants a whole number >= 1, got " + std::string(argv[i]));
      min_views = static_cast<int>(v);
    }
    else if (a == "--no-occlusion")
      occlusion = false;
    else if (a == "--intrinsics" && i + 1 < argc) {
      if (std::sscanf(argv[++i], "%lf,%lf,%lf,%lf,%d,%d", &intrinsics.fx, &intrinsics.fy, &intrinsics.cx,
                      &intrinsics.cy, &intrinsics.width, &intrinsics.height) != 6)
        return Fail("--intrinsics wants fx,fy,cx,cy,width,height");
    } else if (a == "--write-aligned" && i + 1 < argc) {
      write_aligned = argv[++i];
    } else if (a == "--truth-mesh" && i + 1 < argc) {
      truth_mesh = argv[++i];
    } else if (a == "--write-errors" && i + 1 < argc) {
      write_errors = argv[++i];
    } else if (a == "--write-visible" && i + 1 < argc) {
      write_visible = argv[++i];
    } else if (a == "--align" && i + 2 < argc) {
      align_est = argv[++i];
      align_truth = argv[++i];
    } else
      return Fail("unknown option " + a);
  }
  std::vector<Eigen::Vector3d> model, truth, truth_normals, visible;
  if (!ReadPlyPoints(argv[2], &model, &error) ||
      !ReadPlyPoints(argv[3], &truth, &error, visible_from.empty() ? nullptr : &truth_normals))
    return Fail(error);
  std::vector<int> candidates;
  if (visible_from.empty()) {
    for (size_t i = 0; i < truth.size(); ++i) candidates.push_back(static_cast<int>(i));
  } else {
    std::vector<StampedPose> views;
    if (!ReadTumTrajectory(visible_from, &views, &error)) return Fail(error);
    candidates = VisibleSurfacePoints(truth, truth_normals, views, intrinsics, min_views, /*min_cos=*/0.1, occlusion);
  }
  for (int i : candidates)
    if (truth[i].z() >= min_z) visible.push_back(truth[i]);
  if (!align_est.empty()) {
    Sim3 truth_from_estimate;
    if (!TruthFromEstimate(align_est, align_truth, &truth_from_estimate, &error)) return Fail(error);
    for (auto& p : model) p = truth_from_estimate * p;
  }
  if (!write_aligned.empty() && !WriteXyz(write_aligned, model, &error)) return Fail(error);
  if (!write_visible.empty() && !WriteXyz(write_visible, visible, &error)) return Fail(error);
  std::vector<double> distances;
  const SurfaceEvaluation samples = EvaluateSurface(model, truth, visible, threshold, &distances);
  const SurfaceEvaluation v = EvaluateSurface(model, visible, threshold);
  SurfaceEvaluation s = samples;
  if (!truth_mesh.empty()) {
    std::vector<Eigen::Vector3d> mesh_vertices;
    std::vector<Eigen::Vector3i> mesh_triangles;
    if (!ReadPlyMesh(truth_mesh, &mesh_vertices, &mesh_triangles, &error)) return Fail(error);
    const MeshDistance distance(mesh_vertices, mesh_triangles);
    if (distance.empty()) return Fail(truth_mesh + ": no usable triangle");
    s = EvaluateSurfaceToMesh(model, distance, visible, threshold, &distances);
  }
  if (!write_errors.empty()) {
    if (distances.empty())
      std::fprintf(stderr, "warning: %s: no distances (no model points, or no truth points to score against)\n",
                   write_errors.c_str());
    const std::vector<Eigen::Vector3d> none;  // no distances: an empty file
    if (!WriteXyz(write_errors, distances.empty() ? none : model, &error, &distances)) return Fail(error);
  }
  std::printf(
      "model_points %d\ntruth_points %d\naccuracy_p50 %.4f\naccuracy_p90 %.4f\naccuracy_max %.4f\n"
      "completeness %.4f\nvisible_accuracy_p50 %.4f\nvisible_accuracy_p90 %.4f\nvisible_accuracy_max %.4f\n",
      s.num_model, s.num_truth, s.accuracy_p50, s.accuracy_p90, s.accuracy_max, s.completeness, v.accuracy_p50,
      v.accuracy_p90, v.accuracy_max);
  if (!truth_mesh.empty())
    std::printf("sample_accuracy_p50 %.4f\nsample_accuracy_p90 %.4f\nsample_accuracy_max %.4f\n",
                samples.accuracy_p50, samples.accuracy_p90, samples.accuracy_max);
  return 0;

}

// objscan_evaluate target TARGET.json TRUTH.json [--align EST TRUTH] [--truth-mesh MESH]: the target box's centre
// and size errors. With the true surface (MESH, robot_sim's target_mesh.ply) the true box is the surface's extent
// along the estimated box's yaw (TrueBoxAtYaw), else TRUTH.json's box.
int EvaluateTargetCommand(int argc, char** argv) {
  std::string error;
  std::string align_est, align_truth, truth_mesh;
  for (int i = 4; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--align" && i + 2 < argc) {
      align_est = argv[++i];
      align_truth = argv[++i];
    } else if (a == "--truth-mesh" && i + 1 < argc) {
      truth_mesh = argv[++i];
    } else {
      return Fail("unknown option " + a);
    }
  }
  std::string texts[2];
  for (int k = 0; k < 2; ++k) {
    std::ifstream in(argv[2 + k]);
    if (!in) return Fail(std::string("cannot read ") + argv[2 + k]);
    std::stringstream buffer;
    buffer << in.rdbuf();
    texts[k] = buffer.str();
  }
  // The object finder writes centre_mm (as the issue names it), the simulator center_mm: either is read.
  auto read_box = [](const std::string& text, std::vector<double>* centre, std::vector<double>* size) {
    return (JsonNumbers(text, "centre_mm", 3, centre) || JsonNumbers(text, "center_mm", 3, centre)) &&
           JsonNumbers(text, "size_mm", 3, size);
  };
  std::vector<double> c, sz, tc, tsz;
  if (!read_box(texts[0], &c, &sz)) return Fail(std::string(argv[2]) + ": no centre_mm / size_mm (3 numbers each)");
  if (!read_box(texts[1], &tc, &tsz)) return Fail(std::string(argv[3]) + ": no centre_mm / size_mm (3 numbers each)");
  Sim3 truth_from_estimate;
  if (!align_est.empty() && !TruthFromEstimate(align_est, align_truth, &truth_from_estimate, &error))
    return Fail(error);
  Eigen::Vector3d true_center(tc[0], tc[1], tc[2]), true_size(tsz[0], tsz[1], tsz[2]);
  if (!truth_mesh.empty()) {
    std::vector<double> yaw;
    if (!JsonNumbers(texts[0], "yaw_rad", 1, &yaw)) return Fail(std::string(argv[2]) + ": no yaw_rad");
    std::vector<Eigen::Vector3d> vertices;
    std::vector<Eigen::Vector3i> triangles;
    if (!ReadPlyMesh(truth_mesh, &vertices, &triangles, &error)) return Fail(error);
    if (!TrueBoxAtYaw(vertices, YawInTruthFrame(yaw[0], truth_from_estimate), &true_center, &true_size))
      return Fail(truth_mesh + ": no vertices");
  }
  const TargetEvaluation t =
      EvaluateTarget({c[0], c[1], c[2]}, {sz[0], sz[1], sz[2]}, true_center, true_size, truth_from_estimate);
  std::printf("center_error_mm %.3f\ncenter_error_xy_mm %.3f\ncenter_x %.3f\ncenter_y %.3f\ncenter_z %.3f\n"
              "size_error_major_mm %.3f\nsize_error_minor_mm %.3f\nsize_error_height_mm %.3f\n",
              t.center_error_mm, t.center_error_xy_mm, t.center_aligned_mm.x(), t.center_aligned_mm.y(),
              t.center_aligned_mm.z(), t.size_error_mm.x(), t.size_error_mm.y(), t.size_error_mm.z());
  return 0;
}
}  // namespace

int main(int argc, char** argv) {
  using namespace objscan;
  const bool help = argc == 2 && (std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h");
  if (argc < 4) {
    std::fprintf(help ? stdout : stderr,
                 "usage: objscan_evaluate trajectory EST TRUTH [--no-scale] [--max-dt S]\n"
                 "       objscan_evaluate surface MODEL.ply TRUTH.ply [--threshold D] [--min-z Z] "
                 "[--align EST TRUTH] [--truth-mesh MESH] [--visible-from POSES] [--min-views N] [--no-occlusion] "
                 "[--intrinsics fx,fy,cx,cy,w,h] [--write-aligned F] [--write-visible F] [--write-errors F]\n"
                 "       objscan_evaluate target TARGET.json TRUTH.json [--align EST TRUTH] [--truth-mesh MESH]\n");
    return help ? 0 : 2;
  }
  const std::string command = argv[1];
  if (command == "trajectory") return EvaluateTrajectoryCommand(argc, argv);
  if (command == "surface") return EvaluateSurfaceCommand(argc, argv);
  if (command == "target") return EvaluateTargetCommand(argc, argv);
  return Fail("unknown command " + command);
}
