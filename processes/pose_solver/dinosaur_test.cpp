// Real tracks: the Oxford VGG dinosaur turntable (36 frames, 10 deg steps, ../shared/data/oxford_dinosaur
// (common/test_data.h), see SOURCE.txt; viff.xy holds (row, column) pairs, -1 = missing). No metric calibration exists,
// so a plausible K is ASSUMED: f = 2700 px (between the non-metric RQ factors 3217 / 2292 of the published P matrices),
// principal point at the image centre, no skew. On a run of consecutive frames: factorization + perspective BA of the
// tracks common to all of them (ReconstructSpan), then triangulation of every other track seen in >= 2 of the frames
// and a BA of all. Reported: reprojection RMS (target <= 0.5 px). Skipped when the data are not present.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "common/test_data.h"
#include "processes/pose_solver/pose_estimator.h"

namespace objscan {
namespace {

std::string DataPath() { return SharedDataPath("oxford_dinosaur/viff.xy"); }

TEST(Dinosaur, FactorizationAndBundleAdjustmentOnRealTracks) {
  std::ifstream in(DataPath());
  if (!in) GTEST_SKIP() << "no data at " << DataPath();
  std::vector<std::vector<Eigen::Vector2d>> tracks;  // [track][frame], (-1, -1) = missing
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::vector<Eigen::Vector2d> t;
    double a, b;
    while (s >> a >> b) t.push_back(a < 0 || b < 0 ? Eigen::Vector2d(-1, -1) : Eigen::Vector2d(b, a));
    if (t.size() == 36) tracks.push_back(t);
  }
  ASSERT_EQ(tracks.size(), 4983u);
  PinholeCamera camera;
  camera.width = 720;
  camera.height = 576;
  camera.fx = camera.fy = 2700;
  camera.cx = 359.5;
  camera.cy = 287.5;
  const int first = 19, num = 6;
  std::vector<int> common;
  for (size_t t = 0; t < tracks.size(); ++t) {
    bool all = true;
    for (int f = first; f < first + num; ++f) all = all && tracks[t][f].x() >= 0;
    if (all) common.push_back(static_cast<int>(t));
  }
  ASSERT_GE(common.size(), 50u);
  std::vector<std::vector<Eigen::Vector2d>> meas(num);
  for (int f = 0; f < num; ++f)
    for (int t : common) meas[f].push_back(tracks[t][first + f]);
  BaOptions bo;
  bo.max_iterations = 100;
  BaProblem span;
  double span_rms = 0;
  std::string why;
  ASSERT_TRUE(ReconstructSpan(camera, meas, bo, &span, &span_rms, &why)) << why;
  FactorizationResult fr;
  ASSERT_TRUE(FactorizeWeakPerspective(meas, &fr, &why));
  // Every other track seen in >= 2 of the frames: triangulate, then adjust everything.
  BaProblem all = span;
  TriangulationOptions to;
  to.min_parallax_deg = 1.0;
  to.max_reprojection_px = 2.0;
  int tried = 0;
  for (size_t t = 0; t < tracks.size(); ++t) {
    if (std::binary_search(common.begin(), common.end(), static_cast<int>(t))) continue;
    std::vector<Eigen::Isometry3d> poses;
    std::vector<Eigen::Vector2d> px;
    std::vector<int> frames;
    for (int f = 0; f < num; ++f)
      if (tracks[t][first + f].x() >= 0) {
        poses.push_back(span.world_from_camera[f]);
        px.push_back(tracks[t][first + f]);
        frames.push_back(f);
      }
    if (poses.size() < 2) continue;
    ++tried;
    TriangulatedPoint tp;
    if (!TriangulatePoint(camera, poses, px, to, &tp)) continue;
    const int index = static_cast<int>(all.points.size());
    all.points.push_back(tp.point_in_world);
    for (size_t k = 0; k < frames.size(); ++k) all.observations.push_back({frames[k], index, px[k]});
  }
  const BaSummary s = RunBundleAdjustment(camera, RobotGeometry(), bo, &all);
  ASSERT_TRUE(s.ok) << s.message;
  std::printf(
      "dinosaur frames %d..%d: %zu common tracks, affine factorization RMS %.3f px, perspective span BA RMS "
      "%.3f px; with %zu/%d more triangulated tracks: %zu observations, BA RMS %.3f px (before %.3f)\n",
      first, first + num - 1, common.size(), fr.residual_rms_px, span_rms, all.points.size() - common.size(), tried,
      all.observations.size(), s.final_rms_px, s.initial_rms_px);
  EXPECT_LE(span_rms, 1.0);  // 94 common tracks only, non-robust RMS (measured 0.62 px)
  EXPECT_LE(s.final_rms_px, 0.5);
  EXPECT_GE(all.points.size(), common.size() + 100);
}

}  // namespace
}  // namespace objscan
