#include "processes/dense_modeler/affine_dense.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>

#include "processes/dense_modeler/synthetic_scene.h"

namespace objscan {
namespace {

// A textured plane n . X = d (world) seen by two cameras.
struct PlaneScene {
  Eigen::Vector3d n;
  double d;
  PinholeCamera camera = testing_scene::DefaultCamera();

  bool Intersect(const Eigen::Isometry3d& pose, const Eigen::Vector2d& px, Eigen::Vector3d* x) const {
    const Eigen::Vector3d o = pose.translation();
    const Eigen::Vector3d r = pose.linear() * camera.Unproject(px).homogeneous();
    const double den = n.dot(r);
    if (std::abs(den) < 1e-12) return false;
    const double s = (d - n.dot(o)) / den;
    if (s <= 0) return false;
    *x = o + s * r;
    return true;
  }
  cv::Mat Render(const Eigen::Isometry3d& pose) const {
    cv::Mat img(camera.height, camera.width, CV_8UC3, cv::Scalar(0, 0, 0));
    for (int v = 0; v < camera.height; ++v)
      for (int u = 0; u < camera.width; ++u) {
        Eigen::Vector3d x;
        if (!Intersect(pose, Eigen::Vector2d(u, v), &x)) continue;
        const auto t = testing_scene::Texture(x);
        img.at<cv::Vec3b>(v, u) = cv::Vec3b(t[0], t[1], t[2]);
      }
    return img;
  }
  // Matches: 3-D points on a grid over A's image, projected into both.
  std::vector<PointMatch> Matches(const Eigen::Isometry3d& pa, const Eigen::Isometry3d& pb, int spacing_px) const {
    std::vector<PointMatch> out;
    for (int v = 20; v < camera.height - 20; v += spacing_px)
      for (int u = 20; u < camera.width - 20; u += spacing_px) {
        const Eigen::Vector2d p(u + 0.37 * ((v / spacing_px) % 3), v + 0.21 * ((u / spacing_px) % 4));
        Eigen::Vector3d x;
        Eigen::Vector2d q;
        if (!Intersect(pa, p, &x) || !camera.Project(pb.inverse() * x, &q) || !camera.InImage(q, 5)) continue;
        out.push_back({p, q});
      }
    return out;
  }
};

DenseView View(const PinholeCamera& cam, const Eigen::Isometry3d& pose, const cv::Mat& image) {
  DenseView v;
  v.camera = cam;
  v.world_from_camera = pose;
  v.image = image;
  return v;
}

// The floor-like plane z = 1000 seen from A at the origin and from B 150 mm to its side (same orientation, a
// horizontal baseline: epipolar lines are rows), both views rendered.
struct SidewaysPlanePair {
  PlaneScene scene{Eigen::Vector3d::UnitZ(), 1000.0};
  Eigen::Isometry3d pa = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d pb = Eigen::Isometry3d(Eigen::Translation3d(150, 0, 0));
  DenseView a = View(scene.camera, pa, scene.Render(pa));
  DenseView b = View(scene.camera, pb, scene.Render(pb));
};

struct Errors {
  double max_px = 0, max_plane_mm = 0, mean_plane_mm = 0;
  size_t n = 0;
};

Errors Check(const PlaneScene& scene, const Eigen::Isometry3d& pa, const Eigen::Isometry3d& pb,
             const std::vector<DensePoint>& pts) {
  Errors e;
  for (const DensePoint& p : pts) {
    Eigen::Vector3d x;
    Eigen::Vector2d q_true;
    if (!scene.Intersect(pa, p.pixel_a.cast<double>(), &x) || !scene.camera.Project(pb.inverse() * x, &q_true))
      continue;
    e.max_px = std::max(e.max_px, (q_true - p.pixel_b.cast<double>()).norm());
    const double dist = std::abs(scene.n.dot(p.point_in_world) - scene.d);
    e.max_plane_mm = std::max(e.max_plane_mm, dist);
    e.mean_plane_mm += dist;
    ++e.n;
  }
  if (e.n) e.mean_plane_mm /= e.n;
  return e;
}

// A plane tilted against view A (identity pose) and view B rotated 0.12 rad about y and moved 110 mm.
struct TiltedPlanePair {
  PlaneScene scene{Eigen::Vector3d(0.3, -0.2, 1.0).normalized(), 900.0};
  Eigen::Isometry3d pa = Eigen::Isometry3d::Identity(), pb = Eigen::Isometry3d::Identity();
  DenseView a, b;
  TiltedPlanePair() {
    pb.linear() = Eigen::AngleAxisd(-0.12, Eigen::Vector3d::UnitY()).toRotationMatrix();
    pb.translation() = Eigen::Vector3d(110, 10, 5);
    a = View(scene.camera, pa, scene.Render(pa));
    b = View(scene.camera, pb, scene.Render(pb));
  }
};

TEST(AffineDense, AffineMapExactOnFrontoParallelPlane) {
  PlaneScene scene{Eigen::Vector3d::UnitZ(), 1000.0};
  const Eigen::Isometry3d pa = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d pb = Eigen::Isometry3d::Identity();
  pb.translation() = Eigen::Vector3d(120, 25, 60);  // same orientation: the plane maps affinely
  const DenseView a = View(scene.camera, pa, scene.Render(pa)), b = View(scene.camera, pb, scene.Render(pb));
  AffineDenseOptions o;
  o.refine_along_epipolar = false;  // the raw mapping (refinement is tested on its own)
  DensePairStats st;
  const auto pts = ComputeDensePair(a, b, scene.Matches(pa, pb, 40), o, &st);
  const Errors e = Check(scene, pa, pb, pts);
  std::printf("fronto-parallel: %zu points of %lld pixels, max map error %.4f px, plane dist max %.4f mm\n", e.n,
              static_cast<long long>(st.pixels), e.max_px, e.max_plane_mm);
  ASSERT_GT(e.n, 100000u);
  EXPECT_GT(st.accepted, 0.95 * st.pixels);
  EXPECT_LT(e.max_px, 0.1);
  EXPECT_LT(e.max_plane_mm, 0.5);
}

TEST(AffineDense, LargeTrianglesNeedTexturedWindows) {
  // A fronto-parallel plane whose texture is faded to a ~2 gray-level ripple: exact matches that pass the ordinary
  // NCC test, but too flat for the strict checks of triangles longer than strict_triangle_edge_px.
  PlaneScene scene{Eigen::Vector3d::UnitZ(), 1000.0};
  const Eigen::Isometry3d pa = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d pb = Eigen::Isometry3d::Identity();
  pb.translation() = Eigen::Vector3d(120, 25, 60);
  auto faded = [](const cv::Mat& img) {
    cv::Mat out;
    img.convertTo(out, CV_8UC3, 0.04, 128 * 0.96);
    return out;
  };
  const DenseView a = View(scene.camera, pa, faded(scene.Render(pa)));
  const DenseView b = View(scene.camera, pb, faded(scene.Render(pb)));
  AffineDenseOptions o;
  o.min_window_stddev = 0.5;
  std::string why;
  ASSERT_TRUE(ValidateAffineDenseOptions(o, &why)) << why;
  auto accepted_fraction = [&](int spacing_px, double strict_edge_px) {
    AffineDenseOptions oo = o;
    oo.strict_triangle_edge_px = strict_edge_px;
    DensePairStats st;
    ComputeDensePair(a, b, scene.Matches(pa, pb, spacing_px), oo, &st);
    return st.pixels > 0 ? static_cast<double>(st.accepted) / st.pixels : 0.0;
  };
  // Grid spacing 40 px: the triangles' diagonals are ~57 px; 30 px: ~42 px.
  const double large_strict = accepted_fraction(40, 50), large_off = accepted_fraction(40, 1e9);
  const double small_strict = accepted_fraction(30, 50);
  std::printf(
      "faded texture: accepted %.3f of pixels in 57 px triangles (strict), %.3f (not strict), %.3f in 42 px "
      "triangles (strict)\n",
      large_strict, large_off, small_strict);
  EXPECT_LT(large_strict, 0.01);
  EXPECT_GT(large_off, 0.9);
  EXPECT_GT(small_strict, 0.9);
  o.strict_triangle_edge_px = 0;
  EXPECT_FALSE(ValidateAffineDenseOptions(o, &why));
  EXPECT_NE(why.find("strict_triangle_edge_px"), std::string::npos);
}

// The views' grays, given as float or 8-bit (the node makes each frame's once), give the same points as grays
// converted per call; grays of the wrong size or type make the pair unusable instead of being read out of bounds.
TEST(AffineDense, GivenGraysGiveTheSamePointsAndWrongOnesNone) {
  const TiltedPlanePair pair;
  const std::vector<PointMatch> matches = pair.scene.Matches(pair.pa, pair.pb, 40);
  const AffineDenseOptions o;
  const std::vector<DensePoint> own = ComputeDensePair(pair.a, pair.b, matches, o);
  ASSERT_GT(own.size(), 10000u);
  auto same = [&](const DenseView& a, const DenseView& b) {
    const std::vector<DensePoint> pts = ComputeDensePair(a, b, matches, o);
    if (pts.size() != own.size()) return false;
    for (size_t i = 0; i < pts.size(); ++i)
      if (pts[i].pixel_b != own[i].pixel_b || pts[i].point_in_world != own[i].point_in_world) return false;
    return true;
  };
  DenseView a8 = pair.a, b8 = pair.b;
  a8.gray8 = Gray8(a8.image), b8.gray8 = Gray8(b8.image);
  EXPECT_TRUE(same(a8, b8));
  DenseView af = pair.a, bf = pair.b;
  af.gray = GrayFloat(af.image), bf.gray = GrayFloat(bf.image);
  EXPECT_TRUE(same(af, bf));
  EXPECT_TRUE(DensePairViewsUsable(af, b8));
  DenseView small = bf;
  small.gray = bf.gray(cv::Rect(0, 0, 100, 100)).clone();
  EXPECT_FALSE(DensePairViewsUsable(af, small));
  EXPECT_TRUE(ComputeDensePair(af, small, matches, o).empty());
  DenseView wrong_type = b8;
  wrong_type.gray8 = GrayFloat(b8.image);  // CV_32FC1 where CV_8UC1 belongs
  EXPECT_FALSE(DensePairViewsUsable(a8, wrong_type));
  EXPECT_TRUE(DensePairViewsUsable(af, bf));
  DenseView wrong_float = af;
  wrong_float.gray = a8.gray8;  // CV_8UC1 where CV_32FC1 belongs
  EXPECT_FALSE(DensePairViewsUsable(wrong_float, bf));
  // The given grays are the ones used: a flat one leaves no texture to match.
  DenseView flat = bf;
  flat.gray = cv::Mat(bf.image.size(), CV_32FC1, cv::Scalar(128));
  EXPECT_LT(ComputeDensePair(af, flat, matches, o).size(), own.size() / 10);
}

TEST(AffineDense, TiltedPlanePlaneMappingExactAffineClose) {
  const TiltedPlanePair t;
  const PlaneScene& scene = t.scene;
  const Eigen::Isometry3d &pa = t.pa, &pb = t.pb;
  const DenseView &a = t.a, &b = t.b;
  AffineDenseOptions o;
  o.refine_along_epipolar = false;  // the raw mapping (refinement is tested on its own)
  o.mapping = static_cast<int>(DenseMapping::kPlane);
  const auto plane_pts = ComputeDensePair(a, b, scene.Matches(pa, pb, 40), o);
  const Errors ep = Check(scene, pa, pb, plane_pts);
  o.mapping = static_cast<int>(DenseMapping::kAffine);
  const auto affine_pts = ComputeDensePair(a, b, scene.Matches(pa, pb, 40), o);
  const Errors ea = Check(scene, pa, pb, affine_pts);
  std::printf("tilted plane, plane mapping: %zu points, max %.4f px, plane dist max %.4f mm\n", ep.n, ep.max_px,
              ep.max_plane_mm);
  std::printf("tilted plane, affine mapping: %zu points, max %.4f px, plane dist max %.4f mm mean %.4f\n", ea.n,
              ea.max_px, ea.max_plane_mm, ea.mean_plane_mm);
  ASSERT_GT(ep.n, 100000u);
  EXPECT_LT(ep.max_px, 0.1);
  EXPECT_LT(ep.max_plane_mm, 0.5);
  ASSERT_GT(ea.n, 100000u);
  EXPECT_LT(ea.max_px, 0.5);  // affine is only first order on a perspective-viewed plane
}

TEST(AffineDense, EpipolarCheckRejectsWrongMatches) {
  const SidewaysPlanePair pair;
  const PlaneScene& scene = pair.scene;
  const Eigen::Isometry3d &pa = pair.pa, &pb = pair.pb;
  const DenseView &a = pair.a, &b = pair.b;
  auto matches = scene.Matches(pa, pb, 40);
  for (auto& m : matches) m.b.y() += 4.0;  // 4 px off the epipolar line
  AffineDenseOptions o;
  o.refine_along_epipolar = false;  // the raw mapping (refinement is tested on its own)
  DensePairStats st;
  const auto pts = ComputeDensePair(a, b, matches, o, &st);
  EXPECT_TRUE(pts.empty());
  EXPECT_GT(st.rejected_epipolar, 100000);
  EXPECT_LT(EpipolarDistancePx(EssentialMatrix(pa, pb), scene.camera, scene.camera, Eigen::Vector2d(100, 200),
                               Eigen::Vector2d(30, 200)),
            1e-9);
}

TEST(AffineDense, RadianceCheckRejectsWrongTexture) {
  PlaneScene scene{Eigen::Vector3d::UnitZ(), 1000.0};
  const Eigen::Isometry3d pa = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d pb = Eigen::Isometry3d::Identity();
  pb.translation() = Eigen::Vector3d(150, 0, 0);
  cv::Mat img_b = scene.Render(pb);
  cv::Mat wrong;
  cv::flip(img_b, wrong, 0);  // right geometry, wrong radiance
  const DenseView a = View(scene.camera, pa, scene.Render(pa)), b = View(scene.camera, pb, wrong);
  AffineDenseOptions o;
  o.refine_along_epipolar = false;  // the raw mapping (refinement is tested on its own)
  DensePairStats st;
  const auto pts = ComputeDensePair(a, b, scene.Matches(pa, pb, 40), o, &st);
  std::printf("wrong radiance: %zu of %lld accepted (colour %lld, ncc %lld rejected)\n", pts.size(),
              static_cast<long long>(st.pixels), static_cast<long long>(st.rejected_color),
              static_cast<long long>(st.rejected_ncc));
  EXPECT_LT(pts.size(), 0.05 * st.pixels);
  EXPECT_GT(st.rejected_color + st.rejected_ncc, 0.9 * st.pixels);
}

TEST(AffineDense, EpipolarRefinementFixesAlongLineErrors) {
  const SidewaysPlanePair pair;
  const PlaneScene& scene = pair.scene;
  const Eigen::Isometry3d &pa = pair.pa, &pb = pair.pb;
  const DenseView &a = pair.a, &b = pair.b;
  auto matches = scene.Matches(pa, pb, 40);
  for (size_t i = 0; i < matches.size(); ++i) matches[i].b.x() += (i % 2 ? 0.8 : -0.8);  // along the epipolar line
  AffineDenseOptions o;
  o.refine_along_epipolar = false;  // the raw mapping (refinement is tested on its own)
  o.min_ncc = -1;                   // keep everything: compare the geometry only
  o.max_color_difference = -1;
  const Errors plain = Check(scene, pa, pb, ComputeDensePair(a, b, matches, o));
  o.refine_along_epipolar = true;
  DensePairStats st;
  const Errors refined = Check(scene, pa, pb, ComputeDensePair(a, b, matches, o, &st));
  std::printf(
      "vertex errors 0.8 px along the line: without refinement mean plane dist %.3f mm (max map %.3f px), "
      "with %.3f mm (max map %.3f px), mean shift %.3f px\n",
      plain.mean_plane_mm, plain.max_px, refined.mean_plane_mm, refined.max_px, st.mean_refine_shift_px);
  EXPECT_LT(refined.mean_plane_mm, 0.5 * plain.mean_plane_mm);
}

TEST(AffineDense, MatchesBeyondTheRefinementSearchAreRejected) {
  // Every vertex 4 px off along the epipolar line (as for a triangle whose plane is far from the surface, e.g. across
  // a crease): the true match of every pixel lies beyond the 1.5 px search, so the refinement's best score sits at
  // the end of its range. With the check those pixels are dropped; without it they become wrong points.
  const SidewaysPlanePair pair;
  const PlaneScene& scene = pair.scene;
  const Eigen::Isometry3d &pa = pair.pa, &pb = pair.pb;
  const DenseView &a = pair.a, &b = pair.b;
  auto matches = scene.Matches(pa, pb, 40);
  for (auto& m : matches) m.b.x() += 4.0;
  AffineDenseOptions o;
  o.min_ncc = -1;  // the photometric checks alone would not see it: compare the search check only
  o.max_color_difference = -1;
  o.reject_refine_at_border = false;
  DensePairStats off;
  const auto kept_off = ComputeDensePair(a, b, matches, o, &off);
  o.reject_refine_at_border = true;
  DensePairStats on;
  const auto kept_on = ComputeDensePair(a, b, matches, o, &on);
  std::printf("vertices 4 px off along the line: %zu points without the check, %zu with (%lld at the border)\n",
              kept_off.size(), kept_on.size(), static_cast<long long>(on.rejected_refine_border));
  EXPECT_GT(kept_off.size(), 100000u);
  EXPECT_LT(kept_on.size(), 0.05 * kept_off.size());
  EXPECT_GT(on.rejected_refine_border, 0.9 * static_cast<double>(kept_off.size()));
  // Exact tracks: the check costs almost nothing.
  DensePairStats exact;
  const auto kept_exact = ComputeDensePair(a, b, scene.Matches(pa, pb, 40), o, &exact);
  EXPECT_LT(exact.rejected_refine_border, 0.02 * static_cast<double>(kept_exact.size()));
}

// The pixel pairs of a dense pair triangulated again: with the same poses they give the same points; with both
// poses scaled about the origin (the same epipolar geometry) the points scale alike and none is rejected; with B moved
// 3 mm sideways the new epipolar geometry no longer explains the matches and the reprojection check rejects them.
TEST(AffineDense, TriangulateDenseMatchesWithOtherPoses) {
  const TiltedPlanePair t;
  const PlaneScene& scene = t.scene;
  const Eigen::Isometry3d &pa = t.pa, &pb = t.pb;
  const DenseView &a = t.a, &b = t.b;
  const AffineDenseOptions o;
  const std::vector<DensePoint> pts = ComputeDensePair(a, b, scene.Matches(pa, pb, 40), o);
  ASSERT_GT(pts.size(), 50000u);
  const std::vector<DenseMatch> matches = DenseMatchesOf(pts);
  int64_t rejected = -1;
  const std::vector<DensePoint> same =
      TriangulateDenseMatches(scene.camera, pa, scene.camera, pb, matches, o, &rejected);
  EXPECT_EQ(rejected, 0);
  ASSERT_EQ(same.size(), pts.size());
  double worst = 0;
  for (size_t i = 0; i < pts.size(); ++i) {
    worst = std::max(worst, (same[i].point_in_world - pts[i].point_in_world).norm());
    ASSERT_EQ(same[i].bgr, pts[i].bgr);
    ASSERT_EQ(same[i].pixel_a, pts[i].pixel_a);
  }
  EXPECT_LT(worst, 1e-3);  // mm; the kept pixels are floats (ComputeDensePair triangulated the double ones)

  Eigen::Isometry3d sa = pa, sb = pb;
  sa.translation() *= 1.03;
  sb.translation() *= 1.03;
  const std::vector<DensePoint> scaled =
      TriangulateDenseMatches(scene.camera, sa, scene.camera, sb, matches, o, &rejected);
  EXPECT_EQ(rejected, 0);
  ASSERT_EQ(scaled.size(), pts.size());
  worst = 0;
  for (size_t i = 0; i < pts.size(); ++i)
    worst = std::max(worst, (scaled[i].point_in_world - 1.03 * pts[i].point_in_world).norm());
  EXPECT_LT(worst, 1e-3);

  Eigen::Isometry3d moved = pb;
  moved.translation().y() += 3.0;  // perpendicular to the baseline: the epipolar lines move by ~3 px
  const std::vector<DensePoint> off =
      TriangulateDenseMatches(scene.camera, pa, scene.camera, moved, matches, o, &rejected);
  EXPECT_EQ(static_cast<size_t>(rejected) + off.size(), matches.size());
  EXPECT_LT(off.size(), matches.size() / 10);

  EXPECT_TRUE(TriangulateDenseMatches(scene.camera, pa, scene.camera, pa, matches, o, &rejected).empty());
  EXPECT_EQ(rejected, static_cast<int64_t>(matches.size()));
}

TEST(AffineDense, TriangulateMidpointAndDegenerateInput) {
  Eigen::Vector3d x;
  ASSERT_TRUE(TriangulateMidpoint(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(100, 0, 0),
                                  Eigen::Vector3d(-100, 0, 1000).normalized(), &x));
  EXPECT_NEAR((x - Eigen::Vector3d(0, 0, 1000)).norm(), 0, 1e-9);
  EXPECT_FALSE(TriangulateMidpoint(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1, 0, 0),
                                   Eigen::Vector3d(0, 0, 1), &x));
  DenseView a;
  EXPECT_TRUE(ComputeDensePair(a, a, {}, AffineDenseOptions()).empty());
  AffineDenseOptions bad;
  bad.pixel_step = 0;
  std::string why;
  EXPECT_FALSE(ValidateAffineDenseOptions(bad, &why));
}

TEST(AffineDense, WarpedNccSimdPathBitIdenticalToPortableAndCorrect) {
  // Random float images (not only integer gray levels), random warps, integral and sub-pixel p.
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> level(0.0f, 255.0f);
  cv::Mat gray_a(60, 70, CV_32FC1), gray_b(50, 80, CV_32FC1);
  for (cv::Mat* m : {&gray_a, &gray_b})
    for (int v = 0; v < m->rows; ++v)
      for (int u = 0; u < m->cols; ++u) m->at<float>(v, u) = std::floor(level(rng)) + (u % 3 == 0 ? 0.37f * v : 0);
  std::uniform_real_distribution<double> jitter(-0.6, 0.6), ua(0.0, 70.0), va(0.0, 60.0), ub(0.0, 80.0), vb(0.0, 50.0);
  int compared = 0, valid = 0;
  for (int i = 0; i < 3000; ++i) {
    const int h = 1 + i % 5;
    const Eigen::Vector2d p =
        i % 2 ? Eigen::Vector2d(std::floor(ua(rng)), std::floor(va(rng))) : Eigen::Vector2d(ua(rng), va(rng));
    const Eigen::Vector2d q(ub(rng), vb(rng));
    Eigen::Matrix2d j;
    j << 1 + jitter(rng), jitter(rng), jitter(rng), 1 + jitter(rng);
    double sa = -1, sb = -1, pa = -1, pb = -1;
    const double fast = WarpedNcc(gray_a, p, gray_b, q, j, h, &sa, &sb);
    const double portable = WarpedNccPortable(gray_a, p, gray_b, q, j, h, &pa, &pb);
    ++compared;
    EXPECT_EQ(fast, portable);  // bit-identical, including the -2 of windows leaving an image
    EXPECT_EQ(sa, pa);
    EXPECT_EQ(sb, pb);
    if (fast < -1.5) continue;
    ++valid;
    // Reference: plain double-precision NCC of bilinear samples.
    auto bilinear = [](const cv::Mat& m, double x, double y) {
      const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
      const double fx = x - x0, fy = y - y0;
      return (1 - fy) * ((1 - fx) * m.at<float>(y0, x0) + fx * m.at<float>(y0, x0 + 1)) +
             fy * ((1 - fx) * m.at<float>(y0 + 1, x0) + fx * m.at<float>(y0 + 1, x0 + 1));
    };
    std::vector<double> wa, wb;
    for (int dy = -h; dy <= h; ++dy)
      for (int dx = -h; dx <= h; ++dx) {
        wa.push_back(bilinear(gray_a, p.x() + dx, p.y() + dy));
        wb.push_back(bilinear(gray_b, q.x() + j(0, 0) * dx + j(0, 1) * dy, q.y() + j(1, 0) * dx + j(1, 1) * dy));
      }
    double ma = 0, mb = 0;
    for (size_t k = 0; k < wa.size(); ++k) ma += wa[k] / wa.size(), mb += wb[k] / wb.size();
    double cab = 0, caa = 0, cbb = 0;
    for (size_t k = 0; k < wa.size(); ++k)
      cab += (wa[k] - ma) * (wb[k] - mb), caa += (wa[k] - ma) * (wa[k] - ma), cbb += (wb[k] - mb) * (wb[k] - mb);
    EXPECT_NEAR(fast, cab / std::sqrt(caa * cbb), 1e-4);
    EXPECT_NEAR(sa, std::sqrt(caa / wa.size()), 1e-3);
    EXPECT_NEAR(sb, std::sqrt(cbb / wb.size()), 1e-3);
  }
  EXPECT_GT(valid, 1000);
  EXPECT_LT(valid, compared);  // some windows left the images
}

// Every output field and counter equal (bit-identical doubles and floats).
void ExpectSamePoints(const std::vector<DensePoint>& x, const DensePairStats& sx, const std::vector<DensePoint>& y,
                      const DensePairStats& sy, const std::string& what) {
  ASSERT_EQ(x.size(), y.size()) << what;
  size_t differ = 0;
  for (size_t i = 0; i < x.size(); ++i)
    differ += !(x[i].point_in_world == y[i].point_in_world && x[i].bgr == y[i].bgr && x[i].pixel_a == y[i].pixel_a &&
                x[i].pixel_b == y[i].pixel_b && x[i].toward_camera == y[i].toward_camera);
  EXPECT_EQ(differ, 0u) << what;
  EXPECT_EQ(sx.pixels, sy.pixels) << what;
  EXPECT_EQ(sx.accepted, sy.accepted) << what;
  EXPECT_EQ(sx.rejected_outside, sy.rejected_outside) << what;
  EXPECT_EQ(sx.rejected_color, sy.rejected_color) << what;
  EXPECT_EQ(sx.rejected_ncc, sy.rejected_ncc) << what;
  EXPECT_EQ(sx.rejected_refine_border, sy.rejected_refine_border) << what;
  EXPECT_EQ(sx.rejected_triangulation, sy.rejected_triangulation) << what;
  EXPECT_EQ(sx.mean_refine_shift_px, sy.mean_refine_shift_px) << what;
  EXPECT_EQ(sx.refine_searches, sy.refine_searches) << what;
  EXPECT_EQ(sx.refine_full_searches, sy.refine_full_searches) << what;
}

// The fraction of the points of x whose pixel in A is in y with the same pixel in B (bit-identical).
double FractionSameMatch(const std::vector<DensePoint>& x, const std::vector<DensePoint>& y) {
  std::map<std::pair<double, double>, Eigen::Vector2f> b_of;
  for (const DensePoint& p : y) b_of[{p.pixel_a.x(), p.pixel_a.y()}] = p.pixel_b;
  size_t same = 0;
  for (const DensePoint& p : x) {
    auto it = b_of.find({p.pixel_a.x(), p.pixel_a.y()});
    same += it != b_of.end() && it->second == p.pixel_b;
  }
  return x.empty() ? 0.0 : static_cast<double>(same) / x.size();
}

TEST(AffineDense, RefinementSearchesNearThePredictionFirst) {
  // A textured plane, vertices off along the epipolar line by a known amount. The default search scores the 7 steps
  // within 1.5 px of the prediction first and the other 6 of its +-3 px only when their best is at their edge or
  // under NCC 0.95.
  const SidewaysPlanePair pair;
  const PlaneScene& scene = pair.scene;
  const Eigen::Isometry3d &pa = pair.pa, &pb = pair.pb;
  const DenseView &a = pair.a, &b = pair.b;
  AffineDenseOptions o;
  o.pixel_step = 2;
  AffineDenseOptions all = o;
  all.refine_first_steps = 0;  // every step at once
  for (const double shift : {0.0, 2.5}) {
    auto matches = scene.Matches(pa, pb, 40);
    for (auto& m : matches) m.b.x() += shift;
    DensePairStats first, every;
    const auto pts = ComputeDensePair(a, b, matches, o, &first);
    const auto ref = ComputeDensePair(a, b, matches, all, &every);
    std::printf("vertices %.1f px off: %zu points, %lld of %lld searches scored every step; all at once: %zu\n", shift,
                pts.size(), static_cast<long long>(first.refine_full_searches),
                static_cast<long long>(first.refine_searches), ref.size());
    EXPECT_GT(first.refine_searches, 20000);
    EXPECT_EQ(every.refine_searches, first.refine_searches);
    EXPECT_EQ(every.refine_full_searches, every.refine_searches);  // all at once: every step of every search
    if (shift == 0.0) {
      EXPECT_LT(first.refine_full_searches, 0.05 * first.refine_searches);  // peaks at the prediction: 7 steps
      ASSERT_EQ(pts.size(), ref.size());
      EXPECT_EQ(FractionSameMatch(pts, ref), 1.0);  // the peak near the prediction is the best of the whole search
      // The score condition alone sends a search on: B slightly blurred (peaks of NCC < 1, mostly >= 0.95), with
      // NCC 1 required nearly every search scores every step, and finds what the search of every step finds.
      DenseView blurred = b;
      blurred.image = cv::Mat();  // (not b's pixels)
      cv::GaussianBlur(b.image, blurred.image, cv::Size(0, 0), 0.8);
      AffineDenseOptions strict = o;
      strict.refine_first_min_ncc = 1.0;
      DensePairStats st_default, st_strict, st_all;
      ComputeDensePair(a, blurred, matches, o, &st_default);
      const auto pts_strict = ComputeDensePair(a, blurred, matches, strict, &st_strict);
      const auto ref_blurred = ComputeDensePair(a, blurred, matches, all, &st_all);
      std::printf("B blurred: %lld of %lld searches scored every step by default, %lld with NCC 1 required\n",
                  static_cast<long long>(st_default.refine_full_searches),
                  static_cast<long long>(st_default.refine_searches),
                  static_cast<long long>(st_strict.refine_full_searches));
      EXPECT_LT(st_default.refine_full_searches, 0.5 * st_default.refine_searches);
      EXPECT_GT(st_strict.refine_full_searches, 0.99 * st_strict.refine_searches);
      ASSERT_EQ(pts_strict.size(), ref_blurred.size());
      EXPECT_GT(FractionSameMatch(pts_strict, ref_blurred), 0.999);
    } else {
      // Peaks 2.5 px out: nearly every search goes on to every step and finds them (a few stop at a nearer peak
      // of NCC >= 0.95 inside 1.5 px, and differ from the search of every step).
      EXPECT_GT(first.refine_full_searches, 0.99 * first.refine_searches);
      EXPECT_NEAR(static_cast<double>(pts.size()), static_cast<double>(ref.size()), 0.001 * ref.size());
      EXPECT_GT(FractionSameMatch(pts, ref), 0.999);
      EXPECT_GT(pts.size(), 0.9 * first.refine_searches);
    }
  }
  // A search of no more steps than first_steps scores them all at once: the same as first_steps = 0.
  o.refine_search_px = all.refine_search_px = 1.0;
  DensePairStats short_search, short_all;
  const auto pts_short = ComputeDensePair(a, b, scene.Matches(pa, pb, 40), o, &short_search);
  const auto ref_short = ComputeDensePair(a, b, scene.Matches(pa, pb, 40), all, &short_all);
  EXPECT_GT(short_search.refine_searches, 20000);
  EXPECT_EQ(short_search.refine_full_searches, short_search.refine_searches);
  ASSERT_EQ(pts_short.size(), ref_short.size());
  EXPECT_EQ(FractionSameMatch(pts_short, ref_short), 1.0);
  AffineDenseOptions bad;
  bad.refine_first_steps = -1;
  EXPECT_FALSE(ValidateAffineDenseOptions(bad, nullptr));
  bad = AffineDenseOptions();
  bad.refine_first_min_ncc = 1.5;
  EXPECT_FALSE(ValidateAffineDenseOptions(bad, nullptr));
  bad = AffineDenseOptions();
  bad.refine_search_px = 0.25;  // shorter than one step
  EXPECT_FALSE(ValidateAffineDenseOptions(bad, nullptr));
  bad.refine_along_epipolar = false;  // no search: no matter
  EXPECT_TRUE(ValidateAffineDenseOptions(bad, nullptr));
}

TEST(AffineDense, RefinementKernelsBitIdentical) {
  // The batched search (portable and AVX2, with AVX2 window sampling) against the reference (one SSE2 window NCC per
  // step): a tilted plane (a non-trivial window warp), vertices off along and across the epipolar line (shifts,
  // border rejections), windows leaving B near its edges (a long search), several window sizes and step counts
  // (padded lanes), BGR and gray images and float gray levels that are not integers.
  PlaneScene scene{Eigen::Vector3d(0.25, -0.15, 1).normalized(), 1000.0};
  const Eigen::Isometry3d pa = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d pb = Eigen::Isometry3d::Identity();
  pb.translation() = Eigen::Vector3d(140, 25, 0);
  pb.linear() = Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitY()).toRotationMatrix();
  DenseView a = View(scene.camera, pa, scene.Render(pa)), b = View(scene.camera, pb, scene.Render(pb));
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> off(-2.5, 2.5);
  auto matches = scene.Matches(pa, pb, 37);
  // And vertices seen 4 px from B's left and right edges (search windows near them leave B).
  for (int v = 10; v < scene.camera.height - 10; v += 23) {
    bool left = false, right = false;
    for (double u = 0; u < scene.camera.width; u += 0.25) {
      Eigen::Vector3d x;
      Eigen::Vector2d q;
      if (!scene.Intersect(pa, Eigen::Vector2d(u, v), &x) || !scene.camera.Project(pb.inverse() * x, &q)) continue;
      if ((!left && q.x() >= 4.0) || (!right && q.x() >= scene.camera.width - 5.0)) {
        matches.push_back({Eigen::Vector2d(u, v), q});
        (left ? right : left) = true;
      }
    }
  }
  for (auto& m : matches) m.b += Eigen::Vector2d(off(rng), 0.3 * off(rng));
  struct Case {
    int h;
    double search, step;
    int image;        // 0 = BGR, 1 = gray, 2 = float gray levels with fractions
    int pixel_step;   // (a sparser sample of pixels keeps the test short)
    int first_steps;  // AffineDenseOptions::refine_first_steps (3: the default; 0: every step at once)
  };
  const Case cases[] = {{2, 3.0, 0.5, 0, 1, 3},  {2, 3.0, 0.5, 1, 3, 3}, {2, 3.0, 0.5, 2, 3, 3},
                        {1, 2.2, 0.3, 0, 3, 3},  {4, 9.0, 0.5, 0, 3, 3}, {3, 0.5, 0.5, 0, 3, 3},
                        {2, 6.0, 0.25, 2, 3, 3}, {2, 3.0, 0.5, 0, 3, 0}, {2, 6.0, 0.25, 0, 3, 11}};
  int checked = 0;
  int64_t border = 0;
  for (const Case& c : cases) {
    DenseView va = a, vb = b;
    if (c.image >= 1) {
      cv::cvtColor(a.image, va.image, cv::COLOR_BGR2GRAY);
      cv::cvtColor(b.image, vb.image, cv::COLOR_BGR2GRAY);
    }
    if (c.image == 2) {
      va.gray = GrayFloat(va.image) * 0.7 + 3.3;
      vb.gray = GrayFloat(vb.image) * 0.7 + 3.3;
    }
    AffineDenseOptions o;
    o.ncc_half_window = c.h;
    o.refine_search_px = c.search;
    o.refine_step_px = c.step;
    o.min_ncc = 0.5;
    o.pixel_step = c.pixel_step;
    o.refine_first_steps = c.first_steps;
    DensePairStats ref_stats;
    o.refine_kernel = 1;
    const auto ref = ComputeDensePair(va, vb, matches, o, &ref_stats);
    EXPECT_GT(ref.size(), 1000u);
    border += ref_stats.rejected_refine_border;
    // Points whose search reached past the left or right edge of B (the epipolar lines are nearly horizontal): some
    // of their search windows left B.
    int near_edge = 0;
    for (const DensePoint& p : ref)
      near_edge += std::min(p.pixel_b.x(), scene.camera.width - 1 - p.pixel_b.x()) < c.search + 2 * c.h + 1;
    std::printf(
        "h %d search %.2f step %.2f image %d first steps %d: %zu points (%d with search windows leaving B), %lld at "
        "the search border, %lld of %lld searches scored every step\n",
        c.h, c.search, c.step, c.image, c.first_steps, ref.size(), near_edge,
        static_cast<long long>(ref_stats.rejected_refine_border),
        static_cast<long long>(ref_stats.refine_full_searches), static_cast<long long>(ref_stats.refine_searches));
    if (c.search > 5) {
      EXPECT_GT(near_edge, 20);
    }
    for (const int kernel : {0, 2, 3}) {
      o.refine_kernel = kernel;
      DensePairStats st;
      const auto pts = ComputeDensePair(va, vb, matches, o, &st);
      ExpectSamePoints(ref, ref_stats, pts, st,
                       "kernel " + std::to_string(kernel) + " h " + std::to_string(c.h) + " search " +
                           std::to_string(c.search) + " step " + std::to_string(c.step) + " image " +
                           std::to_string(c.image) + " first steps " + std::to_string(c.first_steps));
      ++checked;
    }
  }
  EXPECT_EQ(checked, 27);
  EXPECT_GT(border, 1000);
  AffineDenseOptions bad;
  bad.refine_kernel = 4;
  EXPECT_FALSE(ValidateAffineDenseOptions(bad, nullptr));
}

TEST(AffineDense, FeatureDeduplicationKeepsTheFirstOfCloseMatches) {
  // Random matches with many near-duplicates in A or in B: the features kept must be exactly those of the plain
  // "closer than the separation to an earlier kept match, in A or in B" rule.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 640.0), v(-1.0, 480.0), near(-2.0, 2.0);
  std::vector<PointMatch> matches;
  for (int i = 0; i < 1500; ++i) {
    PointMatch m{{u(rng), v(rng)}, {u(rng), v(rng)}};
    matches.push_back(m);
    if (i % 3 == 0) matches.push_back({m.a + Eigen::Vector2d(near(rng), near(rng)), {u(rng), v(rng)}});
    if (i % 5 == 0) matches.push_back({{u(rng), v(rng)}, m.b + Eigen::Vector2d(near(rng), near(rng))});
  }
  const PinholeCamera cam = testing_scene::DefaultCamera();
  DenseView a, b;
  a.camera = b.camera = cam;
  a.image = cv::Mat(cam.height, cam.width, CV_8UC3, cv::Scalar(0, 0, 0));
  b.image = a.image;
  b.world_from_camera.translation() = Eigen::Vector3d(100, 0, 0);
  for (const double sep : {0.5, 1.5, 3.0, 25.0, -1.0, 0.0}) {
    int expected = 0;
    std::vector<PointMatch> kept;
    for (const PointMatch& m : matches) {
      if (!cam.InImage(m.a) || !cam.InImage(m.b)) continue;
      bool dup = false;
      for (const PointMatch& f : kept)
        dup = dup || (f.a - m.a).squaredNorm() < sep * sep || (f.b - m.b).squaredNorm() < sep * sep;
      if (!dup) kept.push_back(m), ++expected;
    }
    AffineDenseOptions o;
    o.min_feature_separation_px = sep;
    DensePairStats st;
    ComputeDensePair(a, b, matches, o, &st);
    EXPECT_EQ(st.features, expected) << "separation " << sep;
  }
}

// Two views of the floor z = 0 from 700 mm away and 400 mm up, 10 deg apart about the origin, and options with a
// region around it that knows that floor (4 mm clearance).
Eigen::Isometry3d FloorViewA() { return testing_scene::LookAt({0, -700, 400}, {0, 0, 0}); }
Eigen::Isometry3d FloorViewB() {
  const double a10 = 10 * M_PI / 180;
  return testing_scene::LookAt({700 * std::sin(a10), -700 * std::cos(a10), 400}, {0, 0, 0});
}
AffineDenseOptions FloorRegionOptions() {
  AffineDenseOptions o;
  o.region = testing_scene::FloorRegion(Eigen::Vector3d(-1000, -1000, -100), Eigen::Vector3d(1000, 1000, 300));
  return o;
}

// Triangles on the floor are skipped before any pixel work: their points would fall under the floor clearance. A
// floor alone: without the skip every pixel is visited and the few points that pass are wrong (above the clearance);
// with it no pixel is visited. A plane 20 mm above the floor (above the clearance) gives the same points either way.
TEST(AffineDense, FloorTrianglesAreSkipped) {
  const Eigen::Isometry3d pa = FloorViewA(), pb = FloorViewB();
  AffineDenseOptions o = FloorRegionOptions();
  for (const double height : {0.0, 20.0}) {
    PlaneScene plane{Eigen::Vector3d::UnitZ(), height};
    const DenseView a = View(plane.camera, pa, plane.Render(pa)), b = View(plane.camera, pb, plane.Render(pb));
    const std::vector<PointMatch> matches = plane.Matches(pa, pb, 30);
    o.skip_floor_triangles = false;
    DensePairStats all_stats;
    const std::vector<DensePoint> all = ComputeDensePair(a, b, matches, o, &all_stats);
    o.skip_floor_triangles = true;
    DensePairStats skip_stats;
    const std::vector<DensePoint> skip = ComputeDensePair(a, b, matches, o, &skip_stats);
    std::printf("plane %.0f mm above the floor: %lld / %lld pixels visited, %zu / %zu points (skip off / on)\n", height,
                static_cast<long long>(all_stats.pixels), static_cast<long long>(skip_stats.pixels), all.size(),
                skip.size());
    if (height == 0) {
      // Without the skip a few pixels still pass, all of them wrong: more than the clearance above a floor at 0.
      EXPECT_GT(all_stats.pixels, 100000);
      EXPECT_LT(all.size(), 0.001 * static_cast<double>(all_stats.pixels));
      for (const DensePoint& p : all) EXPECT_GT(p.point_in_world.z(), 4.0);
      EXPECT_EQ(skip.size(), 0u);
      EXPECT_GT(all_stats.rejected_box, 0.9 * static_cast<double>(all_stats.pixels));
      EXPECT_EQ(skip_stats.pixels, 0);
      EXPECT_GT(skip_stats.triangles_skipped_region, 100);
    } else {
      ExpectSamePoints(all, all_stats, skip, skip_stats, "plane 20 mm above the floor");
      EXPECT_GT(all.size(), 100000u);
    }
  }
}

TEST(AffineDense, FloorJunctionPixelsThatTheFloorExplainsAreDropped) {
  // Only a textured floor (z = 0) is in view, but every other feature is a false "object" feature 12 mm above it
  // (like the lower rim of an object seen against the floor behind): triangles joining the two put their pixels, which
  // all see the floor, in the air - the crevice curtain. The floor hypothesis finds them out.
  PlaneScene floor{Eigen::Vector3d::UnitZ(), 0.0};
  const Eigen::Isometry3d pa = FloorViewA(), pb = FloorViewB();
  const DenseView a = View(floor.camera, pa, floor.Render(pa)), b = View(floor.camera, pb, floor.Render(pb));
  std::vector<PointMatch> matches;
  int k = 0;
  for (const PointMatch& m : floor.Matches(pa, pb, 30)) {
    Eigen::Vector3d x;
    ASSERT_TRUE(floor.Intersect(pa, m.a, &x));
    if (k++ % 2 == 0) {
      matches.push_back(m);
      continue;
    }
    const Eigen::Vector3d lifted = x + Eigen::Vector3d(0, 0, 12);
    Eigen::Vector2d ua, ub;
    if (floor.camera.Project(pa.inverse() * lifted, &ua) && floor.camera.Project(pb.inverse() * lifted, &ub))
      matches.push_back({ua, ub});
  }
  AffineDenseOptions o = FloorRegionOptions();
  o.junction_min_window_stddev = 0;  // the smooth test texture: only the floor hypothesis decides here
  o.junction_min_ncc = 0.7;
  o.junction_floor_ncc_margin = -1;  // off
  DensePairStats off_stats;
  const std::vector<DensePoint> off = ComputeDensePair(a, b, matches, o, &off_stats);
  o.junction_floor_ncc_margin = 0.1;
  DensePairStats on_stats;
  const std::vector<DensePoint> on = ComputeDensePair(a, b, matches, o, &on_stats);
  std::printf("curtain points: %zu without the floor hypothesis, %zu with (%lld dropped as floor)\n", off.size(),
              on.size(), static_cast<long long>(on_stats.rejected_floor_ambiguous));
  ASSERT_GT(off.size(), 200u);  // without it the air between the floor and the false features is "reconstructed"
  EXPECT_EQ(off_stats.rejected_floor_ambiguous, 0);
  EXPECT_GT(on_stats.rejected_floor_ambiguous, static_cast<int64_t>(off.size()));
  EXPECT_LE(on.size(), off.size() / 20);

  std::string why;
  o.junction_floor_ncc_margin = 3;
  o.junction_floor_min_separation_px = -1;
  EXPECT_FALSE(ValidateAffineDenseOptions(o, &why));
  EXPECT_NE(why.find("junction_floor_ncc_margin"), std::string::npos);
  EXPECT_NE(why.find("junction_floor_min_separation_px"), std::string::npos);
}

}  // namespace
}  // namespace objscan
