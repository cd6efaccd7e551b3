#include "processes/pose_solver/factorization.h"

#include <gtest/gtest.h>

#include <random>

#include "common/geometry.h"

namespace objscan {
namespace {

// Weak-perspective views of a random cloud: the factorization must recover the shape up to a similarity (plus
// the depth reversal) and the relative rotations.
TEST(Factorization, RecoversShapeAndRotationsUpToSimilarity) {
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0, 1);
  Eigen::Matrix3Xd shape(3, 60);
  for (int p = 0; p < 60; ++p) shape.col(p) = Eigen::Vector3d(g(rng), g(rng), g(rng)) * 50.0;
  std::vector<Eigen::Matrix3d> rotations;
  std::vector<std::vector<Eigen::Vector2d>> meas;
  for (int f = 0; f < 12; ++f) {
    const Eigen::Matrix3d r =
        (Eigen::AngleAxisd(0.05 * f, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(0.02 * f, Eigen::Vector3d::UnitX()))
            .toRotationMatrix();
    rotations.push_back(r);
    const double s = 2.0 * (1 + 0.01 * f);
    std::vector<Eigen::Vector2d> row;
    for (int p = 0; p < 60; ++p)
      row.push_back(s * (r * shape.col(p)).head<2>() + Eigen::Vector2d(320 + f, 240 - f) +
                    0.2 * Eigen::Vector2d(g(rng), g(rng)));
    meas.push_back(row);
  }
  FactorizationResult fr;
  std::string why;
  ASSERT_TRUE(FactorizeWeakPerspective(meas, &fr, &why)) << why;
  EXPECT_LT(fr.residual_rms_px, 0.5);
  double best = 1e9;
  for (const FactorizationResult& cand : {fr, fr.Mirrored()}) {
    std::vector<Eigen::Vector3d> a, b;
    for (int p = 0; p < 60; ++p) {
      a.push_back(cand.shape.col(p));
      b.push_back(shape.col(p));
    }
    Sim3 sim;
    ASSERT_TRUE(AlignUmeyama(a, b, true, &sim));
    double sum = 0;
    for (int p = 0; p < 60; ++p) sum += (sim * a[p] - b[p]).squaredNorm();
    const double rms = std::sqrt(sum / 60);
    if (rms < best) {
      best = rms;
      // Relative rotations R_f R_0^T agree (conjugated by the alignment).
      for (int f = 0; f < 12; ++f) {
        const Eigen::Matrix3d rel_true = rotations[f] * rotations[0].transpose();
        const Eigen::Matrix3d rel_est = cand.camera_from_model[f];
        EXPECT_LT(std::abs(RotationAngle(rel_true) - RotationAngle(rel_est)), 0.02) << "frame " << f;
      }
    }
  }
  EXPECT_LT(best, 1.0);  // mm on a 50 mm cloud with 0.2 px noise at scale 2
}

TEST(Factorization, RejectsDegenerateInput) {
  FactorizationResult fr;
  std::string why;
  EXPECT_FALSE(FactorizeWeakPerspective({}, &fr, &why));
  std::vector<std::vector<Eigen::Vector2d>> same(5, std::vector<Eigen::Vector2d>(10, Eigen::Vector2d(1, 2)));
  EXPECT_FALSE(FactorizeWeakPerspective(same, &fr, &why));
  std::vector<std::vector<Eigen::Vector2d>> ragged(4, std::vector<Eigen::Vector2d>(10, Eigen::Vector2d(1, 2)));
  ragged[2].pop_back();
  EXPECT_FALSE(FactorizeWeakPerspective(ragged, &fr, &why));
}

TEST(Factorization, StartSpanNeedsRotationAndCommonTracks) {
  std::mt19937 rng(5);
  std::normal_distribution<double> g(0, 1);
  Eigen::Matrix3Xd shape(3, 40);
  for (int p = 0; p < 40; ++p) shape.col(p) = Eigen::Vector3d(g(rng), g(rng), g(rng)) * 50.0;
  std::vector<TrackList> frames;
  StartSpanOptions o;
  o.min_common_tracks = 30;
  o.min_rotation_deg = 8;
  int first = -1, last = -1;
  for (int f = 0; f < 20; ++f) {
    const Eigen::Matrix3d r = Eigen::AngleAxisd(0.02 * f, Eigen::Vector3d::UnitY()).toRotationMatrix();
    TrackList t;
    for (int p = 0; p < 40; ++p) {
      t.ids.push_back(p);
      t.pixels.push_back(2.0 * (r * shape.col(p)).head<2>() + Eigen::Vector2d(320, 240));
    }
    frames.push_back(t);
    const bool found = SelectStartSpan(frames, o, &first, &last, nullptr);
    // 8 deg needs 0.1396 rad / 0.02 = 7 frames of rotation.
    if (f < 7) {
      EXPECT_FALSE(found) << f;
    }
    if (found) {
      EXPECT_EQ(last, f);
      EXPECT_EQ(first, 0);
      break;
    }
  }
  EXPECT_EQ(last, 7);
  // Too few common tracks: no span.
  for (auto& t : frames) {
    t.ids.resize(20);
    t.pixels.resize(20);
  }
  std::string why;
  EXPECT_FALSE(SelectStartSpan(frames, o, &first, &last, nullptr, &why));
  EXPECT_NE(why.find("tracks do not last"), std::string::npos) << why;  // said in the pose solver's log
  std::vector<TrackList> two(frames.begin(), frames.begin() + 2);
  EXPECT_FALSE(SelectStartSpan(two, o, &first, &last, nullptr, &why));
  EXPECT_NE(why.find("2 frames since the base last stood still"), std::string::npos) << why;
}

// SpanMotionAgreesWithOdometry: a camera backing 60 mm sideways while turning 12 deg (a retrace). The reconstruction
// in another world frame and at another scale agrees; the same span with the motion reconstructed as descent (the
// depth ambiguity of a short span) does not; nor does one moving the opposite way.
std::vector<Eigen::Isometry3d> Retrace(const Eigen::Isometry3d& world_from_start, double scale,
                                       const Eigen::Vector3d& direction_in_camera) {
  std::vector<Eigen::Isometry3d> poses;
  for (int f = 0; f <= 30; ++f) {
    Eigen::Isometry3d relative = Eigen::Isometry3d::Identity();
    relative.linear() = Eigen::AngleAxisd(0.4 * f * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
    relative.translation() = scale * 2.0 * f * direction_in_camera.normalized();
    poses.push_back(world_from_start * relative);
  }
  return poses;
}

TEST(Factorization, SpanMotionMustAgreeWithTheOdometry) {
  Eigen::Isometry3d odometry_start = Eigen::Isometry3d::Identity();
  odometry_start.linear() = Eigen::AngleAxisd(1.2, Eigen::Vector3d(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  odometry_start.translation() = Eigen::Vector3d(-230, 145, 386);
  const std::vector<Eigen::Isometry3d> odometry = Retrace(odometry_start, 1.0, Eigen::Vector3d(1, 0, 0.2));
  Eigen::Isometry3d visual_start = Eigen::Isometry3d::Identity();  // the span's own frame: camera 0 at the origin
  std::string why;
  EXPECT_TRUE(SpanMotionAgreesWithOdometry(Retrace(visual_start, 0.013, Eigen::Vector3d(1, 0, 0.2)), odometry, &why))
      << why;
  // 2 % scale error and 3 mm of noise-like wobble in the odometry: still agrees.
  std::vector<Eigen::Isometry3d> wobbly = Retrace(odometry_start, 1.02, Eigen::Vector3d(1, 0, 0.2));
  for (size_t f = 0; f < wobbly.size(); ++f) wobbly[f].translation().z() += (f % 2 ? 3.0 : -3.0);
  EXPECT_TRUE(SpanMotionAgreesWithOdometry(Retrace(visual_start, 0.5, Eigen::Vector3d(1, 0, 0.2)), wobbly, &why))
      << why;
  // Reconstructed as descent (camera y axis points down) and as moving backwards: disagree, and say by how much.
  EXPECT_FALSE(SpanMotionAgreesWithOdometry(Retrace(visual_start, 0.5, Eigen::Vector3d(0, 1, 0)), odometry, &why));
  EXPECT_NE(why.find("disagrees with the odometry"), std::string::npos) << why;
  EXPECT_FALSE(SpanMotionAgreesWithOdometry(Retrace(visual_start, 0.5, Eigen::Vector3d(-1, 0, -0.2)), odometry, &why));
  // Under 20 mm of odometry travel: not judged.
  EXPECT_TRUE(SpanMotionAgreesWithOdometry(Retrace(visual_start, 0.5, Eigen::Vector3d(0, 1, 0)),
                                           Retrace(odometry_start, 0.25, Eigen::Vector3d(1, 0, 0.2)), &why));
}

}  // namespace
}  // namespace objscan
