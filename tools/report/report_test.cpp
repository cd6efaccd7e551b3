#include "tools/report/report.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "common/adapters.h"
#include "common/lcm_log.h"
#include "objscan/feature_tracks_t.hpp"
#include "objscan/image_t.hpp"
#include "objscan/pose_t.hpp"
#include "tools/report/report_log.h"

namespace objscan {
namespace {

// A 800 mm circle of camera centres at 30 Hz.
std::vector<StampedPose> Circle(int n) {
  std::vector<StampedPose> poses;
  for (int i = 0; i < n; ++i) {
    StampedPose p;
    p.t = i / 30.0;
    const double a = 2 * M_PI * i / n;
    p.world_from_camera.translation() = Eigen::Vector3d(800 * std::cos(a), 800 * std::sin(a), 400);
    p.world_from_camera.linear() = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    poses.push_back(p);
  }
  return poses;
}

TEST(ReportTest, Base64AndEscaping) {
  auto b = [](const std::string& s) { return Base64(std::vector<uint8_t>(s.begin(), s.end())); };
  EXPECT_EQ(b(""), "");
  EXPECT_EQ(b("f"), "Zg==");
  EXPECT_EQ(b("fo"), "Zm8=");
  EXPECT_EQ(b("foobar"), "Zm9vYmFy");
  EXPECT_EQ(HtmlEscape("<a href=\"x\">&</a>"), "&lt;a href=&quot;x&quot;&gt;&amp;&lt;/a&gt;");
}

TEST(ReportTest, AnEstimateInAnotherFrameIsAlignedAndItsErrorsMeasured) {
  const auto truth = Circle(120);
  // The estimate: scaled 0.64, rotated 30 deg, shifted, with 0.5 mm noise on every centre.
  Sim3 s;
  s.scale = 0.64;
  s.rotation = Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  s.translation = Eigen::Vector3d(100, -50, 7);
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0, 0.5);
  std::vector<StampedPose> estimate = truth;
  for (auto& p : estimate) {
    p.world_from_camera = s.Apply(p.world_from_camera);
    p.world_from_camera.translation() += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  }
  std::vector<StampedPose> aligned;
  const auto f = AlignForReport(estimate, truth, &aligned);
  ASSERT_TRUE(f.aligned);
  EXPECT_NEAR(f.scale, 1 / 0.64, 0.01);
  EXPECT_GT(f.ate_rmse_mm, 0.3);  // the noise, scaled back by 1/0.64: about 0.87 mm RMS in 3-D
  EXPECT_LT(f.ate_rmse_mm, 1.5);
  ASSERT_EQ(f.error_mm.size(), truth.size());
  EXPECT_DOUBLE_EQ(f.registered_fraction, 1.0);
  EXPECT_LT((aligned[10].world_from_camera.translation() - truth[10].world_from_camera.translation()).norm(), 5.0);
  // Without a truth nothing is aligned and the estimate is kept as it is.
  const auto none = AlignForReport(estimate, {}, &aligned);
  EXPECT_FALSE(none.aligned);
  EXPECT_EQ(aligned[5].world_from_camera.translation(), estimate[5].world_from_camera.translation());
}

TEST(ReportTest, TheHtmlIsSelfContainedAndSaysWhatItHolds) {
  ReportInputs in;
  in.title = "out/run <1>";
  in.status = "failed";
  in.truth = Circle(90);
  in.final_poses = in.truth;
  in.online_poses = in.truth;
  for (int i = 0; i < 90; ++i) {
    in.frames.t_s.push_back(i / 30.0);
    in.frames.tracks.push_back(i == 40 ? -1 : 300 + i);
    in.frames.tracks_latency_ms.push_back(i == 41 ? std::nan("") : 8.0);
    in.frames.pose_latency_ms.push_back(20.0);
  }
  in.figures.push_back({"model_mesh vs truth", {{"accuracy_p90", "0.31"}}});
  in.pictures.push_back({"model from +x", {0x89, 'P', 'N', 'G'}});
  in.missing.push_back("session.lcmlog");
  const std::string html = RenderReportHtml(in);
  EXPECT_NE(html.find("<title>objscan report: out/run &lt;1&gt;</title>"), std::string::npos);
  EXPECT_NE(html.find("class=\"bad\" id=\"status\">failed<"), std::string::npos);
  EXPECT_NE(html.find("final ATE RMSE after Sim(3) (mm)</td><td>0.0000"), std::string::npos);
  EXPECT_NE(html.find("accuracy_p90</td><td>0.31"), std::string::npos);
  EXPECT_NE(html.find("src=\"data:image/png;base64,iVBORw==\""), std::string::npos);
  EXPECT_NE(html.find("not in this run: session.lcmlog"), std::string::npos);
  EXPECT_EQ(html.find("no data"), std::string::npos);
  // 4 plots: from above, error, tracks, latency.
  size_t svgs = 0;
  for (size_t at = html.find("<svg"); at != std::string::npos; at = html.find("<svg", at + 1)) ++svgs;
  EXPECT_EQ(svgs, 4u);
  // Nothing is fetched: no external src or href, no script.
  EXPECT_EQ(html.find("src=\"http"), std::string::npos);
  EXPECT_EQ(html.find("href="), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_EQ(html.find("nan"), std::string::npos);  // missing values break the lines, never print
}

TEST(ReportTest, FrameSeriesComeFromTheSessionLog) {
  const std::string path = ::testing::TempDir() + "report_test_" + std::to_string(::getpid()) + ".lcmlog";
  LcmLogWriter w;
  std::string error;
  ASSERT_TRUE(w.Open(path, &error)) << error;
  auto put = [&](const std::string& channel, int64_t logged_us, auto& msg) {
    LcmLogEvent e;
    e.channel = channel;
    e.timestamp_us = logged_us;
    e.data.resize(static_cast<size_t>(msg.getEncodedSize()));
    msg.encode(e.data.data(), 0, static_cast<int>(e.data.size()));
    ASSERT_TRUE(w.Write(e, &error)) << error;
  };
  for (int i = 0; i < 5; ++i) {
    const int64_t utime = 1'000'000 + i * 33'333, logged = 5'000'000 + i * 33'333;
    image_t image{};
    image.utime = utime;
    image.seq = i;
    put("CAMERA_IMAGE", logged, image);
    CameraPoseEstimate truth_pose;
    truth_pose.seq = i;
    truth_pose.utime = utime;
    truth_pose.world_from_camera.translation() = Eigen::Vector3d(100.0 * i, 0, 400);
    pose_t truth_msg = PoseToMessage(truth_pose);
    put("GROUND_TRUTH_POSE", logged, truth_msg);
    if (i == 2) continue;  // frame 2: no tracks, no pose
    feature_tracks_t tracks{};
    tracks.utime = utime;
    tracks.seq = i;
    tracks.num_tracks = 10 * i;
    tracks.track_id.assign(tracks.num_tracks, 1);
    tracks.u.assign(tracks.num_tracks, 1.f);
    tracks.v.assign(tracks.num_tracks, 1.f);
    tracks.age.assign(tracks.num_tracks, 0);
    put("FEATURE_TRACKS", logged + 7'000, tracks);
    pose_t pose{};
    pose.utime = utime;
    pose.seq = i;
    put("CAMERA_POSE", logged + 21'000, pose);
  }
  ASSERT_TRUE(w.Close(&error)) << error;
  FrameSeries frames;
  std::string damage;
  std::vector<StampedPose> truth;
  ASSERT_TRUE(ReadFrameSeries(path, &frames, &truth, &damage, &error)) << error;
  std::remove(path.c_str());
  EXPECT_EQ(damage, "");
  ASSERT_EQ(frames.t_s.size(), 5u);
  EXPECT_NEAR(frames.t_s[1], 1.033333, 1e-6);
  EXPECT_EQ(frames.tracks[3], 30);
  EXPECT_EQ(frames.tracks[2], -1);
  EXPECT_NEAR(frames.tracks_latency_ms[4], 7.0, 1e-9);
  EXPECT_NEAR(frames.pose_latency_ms[4], 21.0, 1e-9);
  EXPECT_TRUE(std::isnan(frames.pose_latency_ms[2]));
  // The driver's true poses (a dataset's calibrated views), stamped with their frame's time.
  ASSERT_EQ(truth.size(), 5u);
  EXPECT_NEAR(truth[3].t, 1.099999, 1e-6);
  EXPECT_NEAR(truth[3].world_from_camera.translation().x(), 300.0, 1e-9);
}

}  // namespace
}  // namespace objscan
