#include "tools/evaluate/evaluation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <unistd.h>

#include <fstream>
#include <random>

namespace objscan {
namespace {

std::string Temp(const std::string& name) { return ::testing::TempDir() + "objscan_eval_" + std::to_string(getpid()) + name; }

std::vector<Eigen::Vector3d> SpherePoints(double radius, int n, const Eigen::Vector3d& centre) {
  std::vector<Eigen::Vector3d> out;
  const double golden = M_PI * (3 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1 - 2 * (i + 0.5) / n, r = std::sqrt(1 - z * z), a = golden * i;
    out.push_back(centre + radius * Eigen::Vector3d(r * std::cos(a), r * std::sin(a), z));
  }
  return out;
}

TEST(EvaluationTest, TumRoundTripAndTimestampMatching) {
  std::vector<StampedPose> truth, est;
  for (int i = 0; i < 50; ++i) {
    StampedPose p;
    p.t = i / 30.0;
    const double a = i * 0.1;
    p.world_from_camera.translation() = Eigen::Vector3d(800 * std::cos(a), 800 * std::sin(a), 400);
    p.world_from_camera.linear() = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    truth.push_back(p);
    if (i % 2 == 0) {  // half the frames, scaled by 0.5
      StampedPose q = p;
      q.t += 0.001;  // 1 ms clock offset: still matched
      q.world_from_camera.translation() *= 0.5;
      est.push_back(q);
    }
  }
  std::string error;
  ASSERT_TRUE(WriteTumTrajectory(Temp("t.txt"), truth, {"units: mm"}, &error)) << error;
  std::vector<StampedPose> read;
  ASSERT_TRUE(ReadTumTrajectory(Temp("t.txt"), &read, &error)) << error;
  ASSERT_EQ(read.size(), truth.size());
  EXPECT_NEAR((read[7].world_from_camera.translation() - truth[7].world_from_camera.translation()).norm(), 0, 1e-5);
  TrajectoryEvaluation e;
  ASSERT_TRUE(EvaluateTumTrajectories(est, read, true, 0.005, &e, &error)) << error;
  EXPECT_EQ(e.num_matched, 25);
  EXPECT_NEAR(e.registered_fraction, 0.5, 1e-9);
  EXPECT_NEAR(e.error.scale, 2.0, 1e-6);
  EXPECT_LT(e.error.ate_rmse, 1e-3);
  // Without scale the halved trajectory cannot fit.
  ASSERT_TRUE(EvaluateTumTrajectories(est, read, false, 0.005, &e, &error));
  EXPECT_GT(e.error.ate_rmse, 100);
  // Per matched pose: its time and its error after the alignment, whose largest is ate_max.
  ASSERT_EQ(e.matched_t_s.size(), 25u);
  ASSERT_EQ(e.matched_error.size(), 25u);
  EXPECT_NEAR(e.matched_t_s[3], est[3].t, 1e-12);
  EXPECT_NEAR(*std::max_element(e.matched_error.begin(), e.matched_error.end()), e.error.ate_max, 1e-6);
  std::remove(Temp("t.txt").c_str());
}

TEST(EvaluationTest, SurfaceAccuracyAndCompleteness) {
  // ~2 points per mm^2: point-to-point distances then overestimate by < 0.1 mm.
  const auto truth = SpherePoints(100, 250000, Eigen::Vector3d(0, 0, 100));
  // Model: the upper half of a sphere 1 mm too large.
  std::vector<Eigen::Vector3d> model;
  for (const auto& p : SpherePoints(101, 20000, Eigen::Vector3d(0, 0, 100)))
    if (p.z() > 100) model.push_back(p);
  const SurfaceEvaluation s = EvaluateSurface(model, truth, 2.0);
  EXPECT_NEAR(s.accuracy_p50, 1.0, 0.15);
  EXPECT_NEAR(s.accuracy_p90, 1.0, 0.2);
  EXPECT_NEAR(s.completeness, 0.5, 0.03);
}

// Accuracy against the whole true surface, completeness over the part that could be seen: a model point on an
// unseen part of the surface is accurate, and the unseen part does not count as missing.
TEST(EvaluationTest, AccuracyUsesTheWholeSurfaceCompletenessTheVisiblePart) {
  const auto truth = SpherePoints(100, 250000, Eigen::Vector3d(0, 0, 100));
  std::vector<Eigen::Vector3d> visible;
  for (const auto& p : truth)
    if (p.z() > 30) visible.push_back(p);  // the lowest 30 mm were never seen
  std::vector<Eigen::Vector3d> model;      // the exact sphere, down to z = 10 mm
  for (const auto& p : SpherePoints(100, 20000, Eigen::Vector3d(0, 0, 100)))
    if (p.z() > 10) model.push_back(p);
  const SurfaceEvaluation whole = EvaluateSurface(model, truth, visible, 2.0);
  EXPECT_LT(whole.accuracy_max, 0.6);  // point-to-point: the truth sample spacing
  EXPECT_GT(whole.completeness, 0.99);
  EXPECT_EQ(whole.num_truth, static_cast<int>(visible.size()));
  // Against the visible part only, the correct points below z = 30 score as errors (up to ~14 mm here).
  const SurfaceEvaluation visible_only = EvaluateSurface(model, visible, 2.0);
  EXPECT_GT(visible_only.accuracy_max, 10.0);
  EXPECT_NEAR(visible_only.completeness, whole.completeness, 1e-12);
}

// A model far from the truth (not aligned) gets its exact distance, quickly, not a search over millions of cells.
TEST(EvaluationTest, FarModelPointsGetTheirExactDistance) {
  const auto truth = SpherePoints(100, 20000, Eigen::Vector3d::Zero());
  const std::vector<Eigen::Vector3d> model = {Eigen::Vector3d(1100, 0, 0), Eigen::Vector3d(-1100, 0, 0),
                                              Eigen::Vector3d(0, 0, 5100)};
  const SurfaceEvaluation e = EvaluateSurface(model, truth, 2.0);
  EXPECT_NEAR(e.accuracy_p50, 1000, 1.0);
  EXPECT_NEAR(e.accuracy_max, 5000, 1.0);
  EXPECT_EQ(e.completeness, 0.0);
}

// A unit sphere of points seen by cameras on a ring above it: the visible set is the cap facing the ring, never the
// underside, and a single view is not enough when two are required.
TEST(EvaluationTest, VisibleSurfacePointsKeepsTheCapFacingTheCameras) {
  std::vector<Eigen::Vector3d> points, normals;
  for (int i = 0; i < 2000; ++i) {
    const double z = -1 + 2 * (i + 0.5) / 2000, phi = i * 2.399963;  // Fibonacci sphere, radius 100 mm
    const Eigen::Vector3d n(std::sqrt(1 - z * z) * std::cos(phi), std::sqrt(1 - z * z) * std::sin(phi), z);
    normals.push_back(n);
    points.push_back(100 * n);
  }
  std::vector<StampedPose> cameras;
  for (int k = 0; k < 8; ++k) {
    const double a = k * M_PI / 4;
    const Eigen::Vector3d c(800 * std::cos(a), 800 * std::sin(a), 400);
    const Eigen::Vector3d forward = (-c).normalized();  // looks at the centre
    const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
    const Eigen::Vector3d down = forward.cross(right);
    StampedPose pose;
    pose.world_from_camera.linear() << right, down, forward;
    pose.world_from_camera.translation() = c;
    cameras.push_back(pose);
  }
  ViewIntrinsics intrinsics;
  const std::vector<int> visible = VisibleSurfacePoints(points, normals, cameras, intrinsics, 2, 0.1);
  ASSERT_FALSE(visible.empty());
  int lower = 0;
  for (int i : visible) {
    if (points[i].z() < -90) ++lower;  // normal more than ~64 deg below the horizon
  }
  EXPECT_EQ(lower, 0);               // the underside faces away from every camera
  EXPECT_GT(visible.size(), 1000u);  // more than a hemisphere: cameras look from all sides
  EXPECT_LT(visible.size(), 1900u);  // but not the bottom cap
  // One camera cannot give two views.
  std::vector<StampedPose> one(cameras.begin(), cameras.begin() + 1);
  EXPECT_TRUE(VisibleSurfacePoints(points, normals, one, intrinsics, 2, 0.1).empty());
  EXPECT_FALSE(VisibleSurfacePoints(points, normals, one, intrinsics, 1, 0.1).empty());
}

// Points on a sphere (radius 100 mm) seen by the ring of cameras.
void FibonacciSphere(int count, std::vector<Eigen::Vector3d>* points, std::vector<Eigen::Vector3d>* normals) {
  for (int i = 0; i < count; ++i) {
    const double z = -1 + 2 * (i + 0.5) / count, phi = i * 2.399963;
    const Eigen::Vector3d n(std::sqrt(1 - z * z) * std::cos(phi), std::sqrt(1 - z * z) * std::sin(phi), z);
    normals->push_back(n);
    points->push_back(100 * n);
  }
}

// Convex: no point hides another, so with points denser than the pixels (0.4 mm apart, ~0.45 px) the occlusion
// test keeps exactly the facing set, grazing angles included.
TEST(EvaluationTest, VisibleSurfacePointsOfAConvexObjectIgnoreOcclusion) {
  std::vector<Eigen::Vector3d> points, normals;
  FibonacciSphere(250000, &points, &normals);
  std::vector<StampedPose> cameras;
  for (int k = 0; k < 8; ++k) {
    const double a = k * M_PI / 4;
    const Eigen::Vector3d c(800 * std::cos(a), 800 * std::sin(a), 400);
    const Eigen::Vector3d forward = (-c).normalized();
    const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
    StampedPose pose;
    pose.world_from_camera.linear() << right, forward.cross(right), forward;
    pose.world_from_camera.translation() = c;
    cameras.push_back(pose);
  }
  const ViewIntrinsics intrinsics;
  const std::vector<int> facing = VisibleSurfacePoints(points, normals, cameras, intrinsics, 1, 0.1, false);
  EXPECT_GT(facing.size(), 150000u);
  EXPECT_EQ(VisibleSurfacePoints(points, normals, cameras, intrinsics, 1, 0.1), facing);
}

enum PointKind { kBehindPlate = 0, kWallElsewhere = 1, kPlate = 2, kNearShadowEdge = 3 };

// A wall of points facing the camera 1000 mm away (0.5 mm spacing: denser than the pixels) and a square plate
// (half side 36 mm) `gap` mm in front of it, centred on the optical axis of a camera at the origin looking along +z.
void WallAndPlate(double gap, std::vector<Eigen::Vector3d>* points, std::vector<Eigen::Vector3d>* normals,
                  std::vector<PointKind>* kind) {
  const double shadow = 36 * 1000 / (1000 - gap);  // the plate's shadow on the wall: |x|, |y| < shadow
  for (double x = -150; x <= 150; x += 0.5)
    for (double y = -100; y <= 100; y += 0.5) {
      points->emplace_back(x, y, 1000);
      normals->emplace_back(0, 0, -1);
      const double r = std::max(std::abs(x), std::abs(y));  // 2 mm either side of the shadow's edge: not scored
      kind->push_back(r < shadow - 2 ? kBehindPlate : r > shadow + 2 ? kWallElsewhere : kNearShadowEdge);
    }
  for (double x = -36; x <= 36; x += 0.5)
    for (double y = -36; y <= 36; y += 0.5) {
      points->emplace_back(x, y, 1000 - gap);
      normals->emplace_back(0, 0, -1);
      kind->push_back(kPlate);
    }
}

// The wall's points behind a plate 100 mm or 5 mm in front are hidden, the rest of the wall and the plate are
// seen; without the occlusion test everything facing the camera counts; a plate 1 mm in front (within the 1 mm +
// 1.25 mm pixel footprint tolerance) hides nothing. A second camera 300 mm to the side sees part of the hidden
// wall: it counts with one required view, not with two.
TEST(EvaluationTest, VisibleSurfacePointsHidesPointsBehindOthers) {
  const ViewIntrinsics intrinsics;
  const StampedPose camera;  // at the origin looking along +z
  for (const double gap : {100.0, 5.0, 1.0}) {
    std::vector<Eigen::Vector3d> points, normals;
    std::vector<PointKind> kind;
    WallAndPlate(gap, &points, &normals, &kind);
    std::vector<int> count(4, 0), total(4, 0);
    for (PointKind k : kind) ++total[k];
    for (int i : VisibleSurfacePoints(points, normals, {camera}, intrinsics, 1, 0.1)) ++count[kind[i]];
    EXPECT_EQ(count[kBehindPlate], gap > 2 ? 0 : total[kBehindPlate]) << "gap " << gap;
    EXPECT_EQ(count[kWallElsewhere], total[kWallElsewhere]) << "gap " << gap;
    EXPECT_EQ(count[kPlate], total[kPlate]) << "gap " << gap;
    EXPECT_EQ(VisibleSurfacePoints(points, normals, {camera}, intrinsics, 1, 0.1, false).size(), points.size());
    if (gap != 100.0) continue;
    StampedPose side = camera;
    side.world_from_camera.translation() = Eigen::Vector3d(300, 0, 0);
    int seen_once = 0, seen_twice = 0;  // wall points 10..36 mm right of the axis, behind the plate from the origin
    std::vector<char> once(points.size(), 0);
    for (int i : VisibleSurfacePoints(points, normals, {camera, side}, intrinsics, 1, 0.1)) once[i] = 1;
    std::vector<char> twice(points.size(), 0);
    for (int i : VisibleSurfacePoints(points, normals, {camera, side}, intrinsics, 2, 0.1)) twice[i] = 1;
    for (size_t i = 0; i < points.size(); ++i)
      if (kind[i] == kBehindPlate && points[i].x() > 10) seen_once += once[i], seen_twice += twice[i];
    EXPECT_GT(seen_once, 5000);
    EXPECT_EQ(seen_twice, 0);
  }
}

// A wall seen at 80° or 83° from its normal, turned about the image's y axis or its diagonal (where two points of
// one pixel are up to sqrt(2) pixels apart across the image), does not hide itself.
TEST(EvaluationTest, VisibleSurfacePointsAtGrazingAnglesDoNotHideThemselves) {
  const ViewIntrinsics intrinsics;
  const StampedPose camera;
  for (const Eigen::Vector3d& axis : {Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(1, 1, 0).normalized()})
    for (const double degrees : {80.0, 83.0}) {
      std::vector<Eigen::Vector3d> points, normals;
      const Eigen::Matrix3d turn = Eigen::AngleAxisd(degrees * M_PI / 180, axis).toRotationMatrix();
      for (double x = -150; x <= 150; x += 0.5)
        for (double y = -150; y <= 150; y += 0.5) {
          points.push_back(Eigen::Vector3d(0, 0, 1000) + turn * Eigen::Vector3d(x, y, 0));
          normals.push_back(turn * Eigen::Vector3d(0, 0, -1));
        }
      const std::vector<int> facing = VisibleSurfacePoints(points, normals, {camera}, intrinsics, 1, 0.1, false);
      EXPECT_GT(facing.size(), points.size() / 3) << degrees;
      EXPECT_EQ(VisibleSurfacePoints(points, normals, {camera}, intrinsics, 1, 0.1).size(), facing.size())
          << degrees << " deg about " << axis.transpose();
    }
}


namespace objscan {
namespace {

// A UV sphere (radius r, centre c): rings x segments quads as triangles, poles fanned.
void UvSphere(double r, const Eigen::Vector3d& c, int rings, int segments, std::vector<Eigen::Vector3d>* v,
              std::vector<Eigen::Vector3i>* t) {
  v->clear();
  t->clear();
  v->push_back(c + Eigen::Vector3d(0, 0, r));
  for (int i = 1; i < rings; ++i) {
    const double th = M_PI * i / rings;
    for (int j = 0; j < segments; ++j) {
      const double ph = 2 * M_PI * j / segments;
      v->push_back(c + r * Eigen::Vector3d(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)));
    }
  }
  v->push_back(c - Eigen::Vector3d(0, 0, r));
  const int south = static_cast<int>(v->size()) - 1;
  auto at = [&](int ring, int seg) { return 1 + (ring - 1) * segments + (seg % segments); };
  for (int j = 0; j < segments; ++j) t->emplace_back(0, at(1, j), at(1, j + 1));
  for (int i = 1; i + 1 < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      t->emplace_back(at(i, j), at(i + 1, j), at(i + 1, j + 1));
      t->emplace_back(at(i, j), at(i + 1, j + 1), at(i, j + 1));
    }
  for (int j = 0; j < segments; ++j) t->emplace_back(south, at(rings - 1, j + 1), at(rings - 1, j));
}

TEST(MeshDistanceTest, ExactOnAPlaneAndItsEdgesAndCorners) {
  // Two triangles: the square [0, 10]^2 at z = 0.
  const std::vector<Eigen::Vector3d> v = {{0, 0, 0}, {10, 0, 0}, {10, 10, 0}, {0, 10, 0}};
  const std::vector<Eigen::Vector3i> t = {{0, 1, 2}, {0, 2, 3}};
  const MeshDistance d(v, t);
  EXPECT_NEAR(d.Distance({3, 4, 2.5}), 2.5, 1e-12);   // above the face
  EXPECT_NEAR(d.Distance({5, 5, -1}), 1.0, 1e-12);    // below
  EXPECT_NEAR(d.Distance({13, 5, 4}), 5.0, 1e-12);    // beyond an edge: to the edge
  EXPECT_NEAR(d.Distance({-3, -4, 0}), 5.0, 1e-12);   // beyond a corner: to the corner
  EXPECT_NEAR(d.Distance({7, 7, 0}), 0.0, 1e-12);     // on it
  EXPECT_NEAR(d.Distance({500, 5, 0}), 490.0, 1e-9);  // far outside the grid: searched exhaustively
  EXPECT_TRUE(std::isinf(d.Distance({std::nan(""), 0, 0})));
  EXPECT_TRUE(std::isinf(MeshDistance(v, {}).Distance({0, 0, 0})));
  EXPECT_TRUE(MeshDistance(v, {{0, 1, 7}}).empty());  // index out of range: ignored
}

// Against a finely tessellated sphere the mesh distance is the radial distance (to within the chords' sagitta),
// while the distance to 1 random sample per mm^2 of the same surface carries the samples' spacing.
TEST(MeshDistanceTest, SurfaceAccuracyToTheMeshHasNoSamplingFloor) {
  const Eigen::Vector3d c(0, 0, 100);
  std::vector<Eigen::Vector3d> v;
  std::vector<Eigen::Vector3i> t;
  UvSphere(100, c, 200, 400, &v, &t);  // chords ~1.6 mm: sagitta < 0.004 mm
  const MeshDistance mesh(v, t);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1), offset(-0.5, 0.5);
  std::vector<Eigen::Vector3d> model, samples;
  double worst = 0;
  for (int i = 0; i < 20000; ++i) {
    Eigen::Vector3d dir(u(rng), u(rng), u(rng));
    if (dir.norm() < 0.1 || dir.norm() > 1) continue;
    dir.normalize();
    const double off = i % 100 == 0 ? 3.0 : offset(rng);  // every 100th point 3 mm out
    model.push_back(c + (100 + off) * dir);
    worst = std::max(worst, std::abs(std::abs(off) - mesh.Distance(model.back())));
  }
  EXPECT_LT(worst, 0.01);
  for (int i = 0; i < 125664; ++i) {  // 1 per mm^2, uniform random
    Eigen::Vector3d dir(u(rng), u(rng), u(rng));
    while (dir.norm() < 0.1 || dir.norm() > 1) dir = Eigen::Vector3d(u(rng), u(rng), u(rng));
    samples.push_back(c + 100 * dir.normalized());
  }
  std::vector<double> distances;
  const SurfaceEvaluation to_mesh = EvaluateSurfaceToMesh(model, mesh, samples, 2.0, &distances);
  const SurfaceEvaluation to_samples = EvaluateSurface(model, samples, 2.0);
  std::vector<double> sample_distances;
  EvaluateSurface(model, samples, samples, 2.0, &sample_distances);
  ASSERT_EQ(sample_distances.size(), model.size());
  for (size_t i = 0; i < model.size(); ++i)  // to the nearest sample: never nearer than the surface itself
    ASSERT_GE(sample_distances[i], mesh.Distance(model[i]) - 0.01) << i;
  EXPECT_EQ(*std::max_element(sample_distances.begin(), sample_distances.end()), to_samples.accuracy_max);
  ASSERT_EQ(distances.size(), model.size());  // per point, in model order: the outliers are every 100th
  for (size_t i = 0; i < model.size(); i += 997) EXPECT_DOUBLE_EQ(distances[i], mesh.Distance(model[i]));
  EXPECT_EQ(
      std::count_if(distances.begin(), distances.end(), [](double d) { return d > 2.9; }),
      std::count_if(model.begin(), model.end(), [&](const Eigen::Vector3d& p) { return (p - c).norm() > 102.9; }));
  // |offset| uniform on [0, 0.5]: p50 0.25, p90 0.45; max 3 (the outliers).
  EXPECT_NEAR(to_mesh.accuracy_p50, 0.25, 0.02);
  EXPECT_NEAR(to_mesh.accuracy_p90, 0.45, 0.02);
  EXPECT_NEAR(to_mesh.accuracy_max, 3.0, 0.01);
  EXPECT_GT(to_samples.accuracy_p90, to_mesh.accuracy_p90 + 0.3);  // the sampling floor
  EXPECT_DOUBLE_EQ(to_mesh.completeness, to_samples.completeness);
}

}  // namespace
}  // namespace objscan

TEST(JsonNumbers, ReadsArraysAndScalarsOfOurFiles) {
  const std::string text = R"({"state": "confirmed", "center_mm": [12.5, -3, 1e2], "size_mm":[150,140, 120],
    "yaw_rad": 0.25, "other": {"center_mm": [1, 2, 3]}})";
  std::vector<double> v;
  ASSERT_TRUE(JsonNumbers(text, "center_mm", 3, &v));
  EXPECT_EQ(v, (std::vector<double>{12.5, -3, 100}));  // the first occurrence
  ASSERT_TRUE(JsonNumbers(text, "size_mm", 3, &v));
  EXPECT_EQ(v, (std::vector<double>{150, 140, 120}));
  ASSERT_TRUE(JsonNumbers(text, "yaw_rad", 1, &v));
  EXPECT_DOUBLE_EQ(v[0], 0.25);
  EXPECT_FALSE(JsonNumbers(text, "missing", 1, &v));
  EXPECT_FALSE(JsonNumbers(text, "center_mm", 4, &v));  // only 3 numbers
  EXPECT_FALSE(JsonNumbers(text, "state", 1, &v));       // not a number
  EXPECT_FALSE(JsonNumbers(R"({"center_mm": [1, nan, 2]})", "center_mm", 3, &v));
}

TEST(EvaluateTarget, AppliesTheAlignmentBeforeComparing) {
  // The estimate lives in a frame rotated 90 deg about z, shifted and at half scale.
  Sim3 truth_from_estimate;
  truth_from_estimate.scale = 2.0;
  truth_from_estimate.rotation = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  truth_from_estimate.translation = Eigen::Vector3d(1000, 0, 0);
  const Eigen::Vector3d true_center(1000 - 2 * 20, 2 * 10, 2 * 50 + 3);  // 3 mm too low after alignment
  const TargetEvaluation e = EvaluateTarget({10, 20, 50}, {70, 75, 60}, true_center, {150, 140, 120},
                                            truth_from_estimate);
  EXPECT_NEAR(e.center_error_mm, 3.0, 1e-9);
  EXPECT_NEAR(e.center_error_xy_mm, 0.0, 1e-9);
  EXPECT_NEAR(e.size_error_mm.x(), 0.0, 1e-9);   // 2 x 75 vs 150
  EXPECT_NEAR(e.size_error_mm.y(), 0.0, 1e-9);   // 2 x 70 vs 140
  EXPECT_NEAR(e.size_error_mm.z(), 0.0, 1e-9);   // 2 x 60 vs 120
}

TEST(TrueBoxAtYaw, CentreOfAnIrregularShapeDependsOnTheYaw) {
  // A right triangle's corners (legs 100 mm along x and y, 40 mm high): its world-axis bounds are centred at
  // (50, 50), its bounds along the hypotenuse's direction (yaw 135 deg) elsewhere.
  std::vector<Eigen::Vector3d> v = {{0, 0, 0}, {100, 0, 0}, {0, 100, 0}, {0, 0, 40}, {100, 0, 40}, {0, 100, 40}};
  Eigen::Vector3d centre, size;
  ASSERT_TRUE(TrueBoxAtYaw(v, 0.0, &centre, &size));
  EXPECT_NEAR((centre - Eigen::Vector3d(50, 50, 20)).norm(), 0.0, 1e-9);
  EXPECT_NEAR((size - Eigen::Vector3d(100, 100, 40)).norm(), 0.0, 1e-9);
  ASSERT_TRUE(TrueBoxAtYaw(v, 3 * M_PI / 4, &centre, &size));
  // Along (-1, 1)/sqrt2 the corners span -70.7..70.7 (centre 0); across it, along (-1, -1)/sqrt2: -70.7..0.
  EXPECT_NEAR(size.x(), 100 * std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(size.y(), 50 * std::sqrt(2.0), 1e-9);
  EXPECT_NEAR((centre - Eigen::Vector3d(25, 25, 20)).norm(), 0.0, 1e-9);
  // A box's own centre does not depend on the yaw's quarter turns.
  std::vector<Eigen::Vector3d> box;
  for (int i = 0; i < 8; ++i) box.push_back({i & 1 ? 60.0 : -60.0, i & 2 ? 30.0 : -30.0, i & 4 ? 20.0 : 0.0});
  ASSERT_TRUE(TrueBoxAtYaw(box, M_PI / 2, &centre, &size));
  EXPECT_NEAR((centre - Eigen::Vector3d(0, 0, 10)).norm(), 0.0, 1e-9);
  EXPECT_NEAR((size - Eigen::Vector3d(60, 120, 20)).norm(), 0.0, 1e-9);
  EXPECT_FALSE(TrueBoxAtYaw({}, 0.0, &centre, &size));
}

TEST(YawInTruthFrame, AddsTheAlignmentsTurn) {
  Sim3 truth_from_estimate;
  truth_from_estimate.rotation = Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_NEAR(YawInTruthFrame(0.25, truth_from_estimate), 0.75, 1e-12);
  EXPECT_NEAR(YawInTruthFrame(0.25, Sim3()), 0.25, 1e-12);
}

}  // namespace
}  // namespace objscan
