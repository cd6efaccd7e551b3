#include "processes/dense_modeler/pair_matches.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <string>

#include "processes/dense_modeler/dense_model.h"
#include "processes/dense_modeler/synthetic_scene.h"

namespace objscan {
namespace {

using testing_scene::SphereScene;

// Gray value noise (trilinear between random values on an 8 mm and a 3 mm lattice): blotchy, not periodic, like
// the sim's textures (the sinusoids of testing_scene::Texture repeat every 13-37 mm, and LK locks onto the wrong
// period there as readily as a tracker would).
uint8_t Noise(const Eigen::Vector3d& p) {
  auto lattice = [](int64_t i, int64_t j, int64_t k) {
    uint64_t h =
        static_cast<uint64_t>(i * 73856093) ^ static_cast<uint64_t>(j * 19349663) ^ static_cast<uint64_t>(k * 83492791);
    h ^= h >> 33, h *= 0xff51afd7ed558ccdULL, h ^= h >> 33;
    return static_cast<double>(h % 1000) / 1000.0;
  };
  double v = 0;
  for (const double cell : {8.0, 3.0}) {
    const Eigen::Vector3d q = p / cell;
    const Eigen::Vector3d f = q.array() - q.array().floor();
    const int64_t i = static_cast<int64_t>(std::floor(q.x())), j = static_cast<int64_t>(std::floor(q.y())),
                  k = static_cast<int64_t>(std::floor(q.z()));
    double s = 0;
    for (int c = 0; c < 8; ++c) {
      const int di = c & 1, dj = (c >> 1) & 1, dk = (c >> 2) & 1;
      s += (di ? f.x() : 1 - f.x()) * (dj ? f.y() : 1 - f.y()) * (dk ? f.z() : 1 - f.z()) *
           lattice(i + di, j + dj, k + dk);
    }
    v += cell > 4 ? 150 * s : 80 * s;
  }
  return static_cast<uint8_t>(std::clamp(v + 10, 0.0, 255.0));
}

// The sphere ray-cast with that texture (BGR, background 40).
cv::Mat RenderNoiseSphere(const SphereScene& scene, const Eigen::Isometry3d& world_from_camera) {
  cv::Mat img(scene.camera.height, scene.camera.width, CV_8UC3, cv::Scalar(40, 40, 40));
  const Eigen::Vector3d o = world_from_camera.translation(), oc = o - scene.center;
  const double c = oc.squaredNorm() - scene.radius * scene.radius;
  for (int v = 0; v < img.rows; ++v)
    for (int u = 0; u < img.cols; ++u) {
      const Eigen::Vector3d d =
          (world_from_camera.linear() * scene.camera.Unproject(Eigen::Vector2d(u, v)).homogeneous()).normalized();
      const double b = oc.dot(d), disc = b * b - c;
      if (disc < 0 || -b - std::sqrt(disc) <= 0) continue;
      const uint8_t g = Noise(o + (-b - std::sqrt(disc)) * d);
      img.at<cv::Vec3b>(v, u) = cv::Vec3b(g, g, g);
    }
  return img;
}

// Two rendered views of the sphere 10.9 degrees apart on the 800 mm ring and the features tracked in both; the
// tracker "lost" every feature left of the sphere's centre column in A (a gap like the blob's flat cap).
struct GapPair {
  SphereScene scene;
  DenseView a, b;
  std::vector<PointMatch> all, tracked;
  double gap_u = 0;  // px, A's column of the sphere's centre

  GapPair() {
    const auto features = scene.SurfacePoints(2500);
    for (int k = 0; k < 2; ++k) {
      DenseView& v = k == 0 ? a : b;
      v.camera = scene.camera;
      v.world_from_camera = scene.RingPose(k, 33);  // the pipeline pair: 6 frames of a 200-frame orbit
      v.image = RenderNoiseSphere(scene, v.world_from_camera);
    }
    all = MatchTracks(scene.Tracks(a.world_from_camera, features, 0), scene.Tracks(b.world_from_camera, features, 1));
    Eigen::Vector2d c;
    a.camera.Project(a.world_from_camera.inverse() * scene.center, &c);
    gap_u = c.x();
    for (const PointMatch& m : all)
      if (m.a.x() >= gap_u) tracked.push_back(m);
  }

  // mm, distance of the match's triangulated point from the sphere (infinite when the rays do not meet).
  double SurfaceError(const PointMatch& m) const {
    const Eigen::Vector3d da = (a.world_from_camera.linear() * a.camera.Unproject(m.a).homogeneous()).normalized();
    const Eigen::Vector3d db = (b.world_from_camera.linear() * b.camera.Unproject(m.b).homogeneous()).normalized();
    Eigen::Vector3d x;
    if (!TriangulateMidpoint(a.world_from_camera.translation(), da, b.world_from_camera.translation(), db, &x))
      return std::numeric_limits<double>::infinity();
    return std::abs((x - scene.center).norm() - scene.radius);
  }
};

const GapPair& Pair() {
  static const GapPair pair;
  return pair;
}

double NearestTrackedPx(const std::vector<PointMatch>& tracked, const Eigen::Vector2d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const PointMatch& m : tracked) best = std::min(best, (m.a - p).norm());
  return best;
}

TEST(PairMatches, FillTheTrackersGapWithMatchesOnTheSurface) {
  const GapPair& d = Pair();
  ASSERT_GT(d.tracked.size(), 300u);
  ASSERT_GT(d.all.size(), d.tracked.size() + 300);
  const PairMatchOptions o;
  PairMatchStats st;
  const std::vector<PointMatch> added = AddPairMatches(d.a, d.b, d.tracked, cv::Rect(), RegionOfInterest(), o, &st);
  EXPECT_EQ(st.added, static_cast<int>(added.size()));
  EXPECT_EQ(st.corners,
            st.skipped_floor + st.lost + st.rejected_backward + st.rejected_residual + st.rejected_epipolar + st.added);
  int in_gap = 0, within_2mm = 0;
  double worst = 0;
  for (const PointMatch& m : added) {
    EXPECT_GE(NearestTrackedPx(d.tracked, m.a), o.min_track_distance_px - 1.0) << m.a.transpose();
    const Eigen::Matrix3d e = EssentialMatrix(d.a.world_from_camera, d.b.world_from_camera);
    EXPECT_LE(EpipolarDistancePx(e, d.a.camera, d.b.camera, m.a, m.b), o.max_epipolar_px + 1e-9);
    in_gap += m.a.x() < d.gap_u - o.min_track_distance_px;
    const double err = d.SurfaceError(m);
    within_2mm += err <= 2.0;
    // Corners on the sphere's silhouette see the background too; none may be far off.
    if (m.a.x() < d.gap_u - o.min_track_distance_px) worst = std::max(worst, err);
  }
  // The gap (the sphere's left half) gets matches, and they lie on the sphere.
  EXPECT_GE(in_gap, 50) << st.corners << " corners, " << st.lost << " lost, " << st.rejected_backward << " backward, "
                        << st.rejected_residual << " residual, " << st.rejected_epipolar << " epipolar, " << st.added
                        << " added";
  // Measured: 87 matches, 81 in the gap, error p50 0.45 mm, p90 1.5 mm.
  EXPECT_GE(within_2mm, 0.9 * added.size());
  EXPECT_LE(worst, 5.0);
}

TEST(PairMatches, NothingNearTrackedFeaturesAndOnlyInsideTheRectangle) {
  const GapPair& d = Pair();
  const PairMatchOptions o;
  // With every feature tracked, the sphere has no gap wider than the track distance: at most a few corners.
  PairMatchStats full;
  const std::vector<PointMatch> with_all = AddPairMatches(d.a, d.b, d.all, cv::Rect(), RegionOfInterest(), o, &full);
  for (const PointMatch& m : with_all) EXPECT_GE(NearestTrackedPx(d.all, m.a), o.min_track_distance_px - 1.0);
  PairMatchStats gap;
  const std::vector<PointMatch> with_gap = AddPairMatches(d.a, d.b, d.tracked, cv::Rect(), RegionOfInterest(), o, &gap);
  EXPECT_LT(with_all.size() * 4, with_gap.size());
  // A rectangle around the sphere's upper left quarter only.
  const cv::Rect rect(static_cast<int>(d.gap_u) - 80, 150, 80, 90);
  const std::vector<PointMatch> in_rect = AddPairMatches(d.a, d.b, d.tracked, rect, RegionOfInterest(), o);
  EXPECT_FALSE(in_rect.empty());
  for (const PointMatch& m : in_rect) EXPECT_TRUE(rect.contains(cv::Point(cvRound(m.a.x()), cvRound(m.a.y()))));
}

TEST(PairMatches, AWrongPoseRejectsMatchesOffTheirEpipolarLines) {
  GapPair d = Pair();
  const PairMatchOptions o;
  PairMatchStats right, wrong;
  AddPairMatches(d.a, d.b, d.tracked, cv::Rect(), RegionOfInterest(), o, &right);
  // B's pose tilted by 0.1 deg: its epipolar lines (about horizontal, the cameras move sideways) move by ~1.4 px.
  d.b.world_from_camera.linear() =
      d.b.world_from_camera.linear() * Eigen::AngleAxisd(0.1 * M_PI / 180, Eigen::Vector3d::UnitX()).matrix();
  AddPairMatches(d.a, d.b, d.tracked, cv::Rect(), RegionOfInterest(), o, &wrong);
  EXPECT_GT(wrong.rejected_epipolar, right.rejected_epipolar + 20);
  EXPECT_LT(wrong.added * 4, right.added);
}

TEST(PairMatches, StricterBackwardAndResidualLimitsKeepFewer) {
  const GapPair& d = Pair();
  PairMatchOptions o;
  PairMatchStats loose, strict;
  o.bare_distance_px = 1000;  // every corner is judged by the strict limits
  o.max_backward_error_px = o.bare_max_backward_error_px = 0.3;
  o.max_residual = 100;
  AddPairMatches(d.a, d.b, d.tracked, cv::Rect(), RegionOfInterest(), o, &loose);
  o.max_backward_error_px = 0.02;
  o.max_residual = 2;
  AddPairMatches(d.a, d.b, d.tracked, cv::Rect(), RegionOfInterest(), o, &strict);
  EXPECT_LT(strict.added, loose.added);
  EXPECT_GT(strict.rejected_backward + strict.rejected_residual, loose.rejected_backward + loose.rejected_residual);
}

TEST(PairMatches, BareCornersHaveTheLooserLimits) {
  const GapPair& d = Pair();
  PairMatchOptions o;
  o.max_residual = 0.5;  // no corner passes this
  o.max_backward_error_px = 0.01;
  o.bare_max_backward_error_px = 0.3;
  PairMatchStats all_bare, none_bare;
  o.bare_distance_px = o.min_track_distance_px;  // every corner is bare
  AddPairMatches(d.a, d.b, d.tracked, cv::Rect(), RegionOfInterest(), o, &all_bare);
  EXPECT_EQ(all_bare.rejected_residual, 0);
  EXPECT_GT(all_bare.added, 50);
  o.bare_distance_px = 1000;  // none is
  AddPairMatches(d.a, d.b, d.tracked, cv::Rect(), RegionOfInterest(), o, &none_bare);
  EXPECT_EQ(none_bare.added, 0);
  EXPECT_GT(none_bare.rejected_backward + none_bare.rejected_residual, 0.9 * none_bare.corners);
}

TEST(PairMatches, LucasKanadeStartsAtTheTrackedFeaturesRange) {
  const GapPair& d = Pair();
  PairMatchOptions o;
  PairMatchStats ranged, unguided;
  AddPairMatches(d.a, d.b, d.tracked, cv::Rect(), RegionOfInterest(), o, &ranged);
  // LK starts at A's pixel, tens of pixels off, and without a pyramid cannot get there; the backward pass, started
  // as far from the corner as the forward one moved, then fails too (started at the corner itself it would return
  // there, and this test fails: 2 Dec).
  o.guess_neighbours = 0;
  o.pyramid_levels = 0;
  AddPairMatches(d.a, d.b, d.tracked, cv::Rect(), RegionOfInterest(), o, &unguided);
  EXPECT_LT(unguided.added * 4, ranged.added) << unguided.added << " vs " << ranged.added;
}

TEST(PairMatches, CornersAmongFloorTracksAreNotMatched) {
  const GapPair& d = Pair();
  const PairMatchOptions o;
  RegionOfInterest region =
      testing_scene::FloorRegion(Eigen::Vector3d(-1000, -1000, -1000), Eigen::Vector3d(1000, 1000, 1000));
  PairMatchStats none, all, no_region;
  AddPairMatches(d.a, d.b, d.tracked, cv::Rect(), RegionOfInterest(), o, &no_region);
  region.floor.offset_mm = 1000;  // the floor z = -1000 mm, far below: no tracked feature is on it
  AddPairMatches(d.a, d.b, d.tracked, cv::Rect(), region, o, &none);
  EXPECT_EQ(none.skipped_floor, 0);
  EXPECT_EQ(none.added, no_region.added);
  region.floor.offset_mm = -300;  // a "floor" z = 300 mm above the whole sphere: every tracked feature is under it
  const std::vector<PointMatch> added = AddPairMatches(d.a, d.b, d.tracked, cv::Rect(), region, o, &all);
  EXPECT_TRUE(added.empty());
  EXPECT_EQ(all.skipped_floor, all.corners);
  EXPECT_GT(all.corners, 50);
  PairMatchOptions keep = o;
  keep.skip_floor_corners = false;
  PairMatchStats kept;
  AddPairMatches(d.a, d.b, d.tracked, cv::Rect(), region, keep, &kept);
  EXPECT_EQ(kept.skipped_floor, 0);
  EXPECT_EQ(kept.added, no_region.added);
}

TEST(PairMatches, BadInputGivesNoMatches) {
  const GapPair& d = Pair();
  const PairMatchOptions o;
  DenseView gray_b = d.b;
  cv::cvtColor(d.b.image, gray_b.image, cv::COLOR_BGR2GRAY);
  EXPECT_TRUE(AddPairMatches(d.a, gray_b, d.tracked, cv::Rect(), RegionOfInterest(), o).empty());  // types differ
  DenseView small_b = d.b;
  small_b.image = d.b.image(cv::Rect(0, 0, 320, 240)).clone();
  EXPECT_TRUE(AddPairMatches(d.a, small_b, d.tracked, cv::Rect(), RegionOfInterest(), o).empty());
  DenseView same_place = d.b;
  same_place.world_from_camera = d.a.world_from_camera;
  EXPECT_TRUE(AddPairMatches(d.a, same_place, d.tracked, cv::Rect(), RegionOfInterest(), o).empty());
  EXPECT_TRUE(AddPairMatches(d.a, d.b, d.tracked, cv::Rect(900, 900, 50, 50), RegionOfInterest(), o)
                  .empty());  // outside the image
  DenseView empty_a = d.a;
  empty_a.image = cv::Mat();
  EXPECT_TRUE(AddPairMatches(empty_a, d.b, d.tracked, cv::Rect(), RegionOfInterest(), o).empty());
  DenseView bad_camera = d.b;
  bad_camera.camera.fx = 0;
  EXPECT_TRUE(AddPairMatches(d.a, bad_camera, d.tracked, cv::Rect(), RegionOfInterest(), o).empty());
  DenseView float_a = d.a, float_b = d.b;  // same type, but not 8-bit
  d.a.image.convertTo(float_a.image, CV_32FC3);
  d.b.image.convertTo(float_b.image, CV_32FC3);
  EXPECT_TRUE(AddPairMatches(float_a, float_b, d.tracked, cv::Rect(), RegionOfInterest(), o).empty());
  DenseView nan_pose = d.b;
  nan_pose.world_from_camera.translation().x() = NAN;
  EXPECT_TRUE(AddPairMatches(d.a, nan_pose, d.tracked, cv::Rect(), RegionOfInterest(), o).empty());
  // Non-finite tracked matches (in A or in B) are ignored: no crash, the same result.
  std::vector<PointMatch> with_nan = d.tracked;
  with_nan.push_back({Eigen::Vector2d(NAN, 10), Eigen::Vector2d(10, 10)});
  with_nan.push_back({Eigen::Vector2d(300, 200), Eigen::Vector2d(INFINITY, 10)});
  EXPECT_EQ(AddPairMatches(d.a, d.b, with_nan, cv::Rect(), RegionOfInterest(), o).size(),
            AddPairMatches(d.a, d.b, d.tracked, cv::Rect(), RegionOfInterest(), o).size());
}

// The views' grays, when the caller gives them (the node makes each frame's once), give the same matches; grays of
// the wrong size or type are bad input.
TEST(PairMatches, GivenGraysGiveTheSameMatchesAndWrongOnesNone) {
  const GapPair& d = Pair();
  const PairMatchOptions o;
  const std::vector<PointMatch> own = AddPairMatches(d.a, d.b, d.tracked, cv::Rect(), RegionOfInterest(), o);
  ASSERT_GT(own.size(), 20u);
  DenseView a = d.a, b = d.b;
  a.gray8 = Gray8(a.image), b.gray8 = Gray8(b.image);
  const std::vector<PointMatch> given = AddPairMatches(a, b, d.tracked, cv::Rect(), RegionOfInterest(), o);
  ASSERT_EQ(given.size(), own.size());
  for (size_t i = 0; i < own.size(); ++i) {
    EXPECT_EQ(given[i].a, own[i].a);
    EXPECT_EQ(given[i].b, own[i].b);
  }
  DenseView small_gray = b;
  small_gray.gray8 = b.gray8(cv::Rect(0, 0, 320, 240)).clone();
  EXPECT_TRUE(AddPairMatches(a, small_gray, d.tracked, cv::Rect(), RegionOfInterest(), o).empty());
  DenseView float_gray = b;
  float_gray.gray8 = GrayFloat(b.image);  // CV_32FC1 where CV_8UC1 belongs
  EXPECT_TRUE(AddPairMatches(a, float_gray, d.tracked, cv::Rect(), RegionOfInterest(), o).empty());
  // The given grays are the ones used: a flat A has no corners.
  DenseView flat = a;
  flat.gray8 = cv::Mat(a.image.size(), CV_8UC1, cv::Scalar(128));
  EXPECT_TRUE(AddPairMatches(flat, b, d.tracked, cv::Rect(), RegionOfInterest(), o).empty());
}

TEST(PairMatches, OptionsAreValidated) {
  std::string why;
  EXPECT_TRUE(ValidatePairMatchOptions(PairMatchOptions(), &why)) << why;
  PairMatchOptions o;
  o.window_px = 14;
  EXPECT_FALSE(ValidatePairMatchOptions(o, &why));
  EXPECT_NE(why.find("window"), std::string::npos) << why;
  o = PairMatchOptions();
  o.max_residual = 0;
  EXPECT_FALSE(ValidatePairMatchOptions(o, &why));
  EXPECT_NE(why.find("max_residual"), std::string::npos) << why;
  o = PairMatchOptions();
  o.corner_quality = 1;
  EXPECT_FALSE(ValidatePairMatchOptions(o, &why));
  o = PairMatchOptions();
  o.min_track_distance_px = 1e10;  // would overflow the mask's disc radius
  EXPECT_FALSE(ValidatePairMatchOptions(o, &why));
  o = PairMatchOptions();
  o.bare_distance_px = 5;  // under min_track_distance_px: every corner would be bare
  EXPECT_FALSE(ValidatePairMatchOptions(o, &why));
  o = PairMatchOptions();
  o.bare_max_backward_error_px = 0.05;  // stricter than the non-bare limit
  EXPECT_FALSE(ValidatePairMatchOptions(o, &why));
  o = PairMatchOptions();
  o.pyramid_levels = 7;
  EXPECT_FALSE(ValidatePairMatchOptions(o, &why));
  const GapPair& d = Pair();
  EXPECT_TRUE(AddPairMatches(d.a, d.b, d.tracked, cv::Rect(), RegionOfInterest(), o)
                  .empty());  // invalid options: nothing, no throw
}

}  // namespace
}  // namespace objscan
