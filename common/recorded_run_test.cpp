#include "common/recorded_run.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

namespace objscan {
namespace {
namespace fs = std::filesystem;

class RecordedRunTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("objscan_recorded_run_test_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override { fs::remove_all(root_); }
  std::string Write(const std::string& name, const std::string& text) {
    const fs::path p = root_ / name;
    std::ofstream(p) << text;
    return p.string();
  }
  fs::path root_;
};

TEST_F(RecordedRunTest, OdometryReadsBackExactly) {
  std::vector<OdometryReading> written;
  for (int i = 0; i < 5; ++i) {
    OdometryReading r;
    r.utime = 1700000000000000 + i * 33333 + 15000;
    r.seq = i;
    r.x_mm = 0.1 * i + 1.0 / 3.0;
    r.y_mm = -2.5e-7 * i;
    r.theta_rad = 0.01 * i;
    r.pan_rad = -0.3;
    r.tilt_rad = 0.4 + 1e-9 * i;
    r.v_mm_s = 200;
    r.omega_rad_s = 0.25;
    r.pan_rate_rad_s = -0.01;
    r.tilt_rate_rad_s = 0.02;
    written.push_back(r);
  }
  const std::string path = (root_ / "odometry.txt").string();
  std::string error;
  ASSERT_TRUE(WriteOdometryFile(path, written, &error)) << error;
  std::vector<OdometryReading> read;
  ASSERT_TRUE(ReadOdometryFile(path, &read, &error)) << error;
  ASSERT_EQ(read.size(), written.size());
  for (size_t i = 0; i < read.size(); ++i) {
    EXPECT_EQ(read[i].utime, written[i].utime);
    EXPECT_EQ(read[i].seq, written[i].seq);
    EXPECT_EQ(read[i].x_mm, written[i].x_mm);
    EXPECT_EQ(read[i].y_mm, written[i].y_mm);
    EXPECT_EQ(read[i].tilt_rad, written[i].tilt_rad);
    EXPECT_EQ(read[i].tilt_rate_rad_s, written[i].tilt_rate_rad_s);
  }
}

TEST_F(RecordedRunTest, OdometryRefusesBadLinesWithTheirNumber) {
  std::vector<OdometryReading> r;
  std::string error;
  const std::string good = "0.1 100000 0 0 0 0 0 0 0 0 0 0\n";
  EXPECT_FALSE(ReadOdometryFile(Write("a.txt", good + "0.2 200000 1 0 0 0 0 0\n"), &r, &error));
  EXPECT_NE(error.find("a.txt:2: expected 12 columns"), std::string::npos) << error;
  EXPECT_FALSE(ReadOdometryFile(Write("b.txt", "# c\n" + good + "0.2 200000 1 nan 0 0 0 0 0 0 0 0\n"), &r, &error));
  EXPECT_NE(error.find("b.txt:3: a value is not a finite number"), std::string::npos) << error;
  EXPECT_FALSE(ReadOdometryFile(Write("c.txt", good + "0.1 100000 1 0 0 0 0 0 0 0 0 0\n"), &r, &error));
  EXPECT_NE(error.find("c.txt:2: utime_us 100000 does not increase"), std::string::npos) << error;
  EXPECT_FALSE(ReadOdometryFile(Write("d.txt", "5.0 100000 0 0 0 0 0 0 0 0 0 0\n"), &r, &error));
  EXPECT_NE(error.find("disagrees"), std::string::npos) << error;
  EXPECT_FALSE(ReadOdometryFile(Write("e.txt", "0.1 100000 0 0 0 0 0 0 0 0 0 1mm\n"), &r, &error));
  EXPECT_FALSE(ReadOdometryFile((root_ / "missing.txt").string(), &r, &error));
  EXPECT_NE(error.find("cannot read"), std::string::npos);
}

TEST_F(RecordedRunTest, FrameTimesReadBackAndRefuseRepeatsAndMalformedLines) {
  std::string error;
  const std::string path = (root_ / "timestamps.txt").string();
  ASSERT_TRUE(WriteFrameTimes(path, {{"000000.png", 0}, {"000001.png", 33333}}, &error)) << error;
  std::vector<FrameTime> times;
  ASSERT_TRUE(ReadFrameTimes(path, &times, &error)) << error;
  ASSERT_EQ(times.size(), 2u);
  EXPECT_EQ(times[1].file_name, "000001.png");
  EXPECT_EQ(times[1].utime, 33333);
  EXPECT_FALSE(ReadFrameTimes(Write("t1.txt", "a.png 1\na.png 2\n"), &times, &error));
  EXPECT_NE(error.find("t1.txt:2: a.png listed twice"), std::string::npos) << error;
  EXPECT_FALSE(ReadFrameTimes(Write("t2.txt", "a.png 1.5\n"), &times, &error));
  EXPECT_NE(error.find("t2.txt:1:"), std::string::npos) << error;
}

TEST_F(RecordedRunTest, RobotFileReadsBackAndMapsTheEncoderConvention) {
  RobotDescription robot;
  robot.geometry.mast_height_mm = 452.5;
  robot.geometry.camera_offset_mm = Eigen::Vector3d(35, -2, 4);
  robot.pan_sign = -1;
  robot.tilt_zero_rad = 0.1;
  robot.footprint_radius_mm = 260;
  robot.max_speed_mm_s = 350;
  robot.tilt_max_deg = 45;
  std::string error;
  const std::string path = (root_ / "robot.cfg").string();
  ASSERT_TRUE(WriteRobotFile(path, robot, &error)) << error;
  RobotDescription read;
  ASSERT_TRUE(ReadRobotFile(path, &read, &error)) << error;
  EXPECT_EQ(read.geometry.mast_height_mm, 452.5);
  EXPECT_EQ(read.geometry.camera_offset_mm, robot.geometry.camera_offset_mm);
  EXPECT_EQ(read.pan_sign, -1);
  EXPECT_EQ(read.tilt_zero_rad, 0.1);
  EXPECT_EQ(read.footprint_radius_mm, 260);
  EXPECT_EQ(read.max_speed_mm_s, 350);
  EXPECT_EQ(read.max_omega_deg_s, 90);  // the default, written and read back
  EXPECT_EQ(read.tilt_max_deg, 45);
  RobotDescription bad;
  EXPECT_FALSE(ReadRobotFile(Write("limits1.cfg", "mast_height_mm = 400\nfootprint_radius_mm = 0\n"), &bad, &error));
  EXPECT_NE(error.find("footprint_radius_mm"), std::string::npos) << error;
  EXPECT_FALSE(ReadRobotFile(Write("limits2.cfg", "mast_height_mm = 400\ntilt_min_deg = 70\n"), &bad, &error));
  EXPECT_NE(error.find("tilt_min_deg < tilt_max_deg"), std::string::npos) << error;

  OdometryReading encoder;
  encoder.pan_rad = 0.3;  // this robot's encoder: positive = right
  encoder.tilt_rad = 0.5;
  encoder.pan_rate_rad_s = 0.2;
  const OdometryReading r = read.ToObjscanConvention(encoder);
  EXPECT_DOUBLE_EQ(r.pan_rad, -0.3);
  EXPECT_DOUBLE_EQ(r.tilt_rad, 0.4);
  EXPECT_DOUBLE_EQ(r.pan_rate_rad_s, -0.2);
}

TEST_F(RecordedRunTest, RobotFileRefusesWhatItCannotTrust) {
  RobotDescription robot;
  std::string error;
  EXPECT_FALSE(ReadRobotFile(Write("r1.cfg", "camera_offset_x_mm = 40\n"), &robot, &error));
  EXPECT_NE(error.find("mast_height_mm is required"), std::string::npos) << error;
  EXPECT_FALSE(ReadRobotFile(Write("r2.cfg", "mast_height_mm = 400\nmast_hieght_mm = 1\n"), &robot, &error));
  EXPECT_NE(error.find("r2.cfg:2: unknown name 'mast_hieght_mm'"), std::string::npos) << error;
  EXPECT_FALSE(ReadRobotFile(Write("r3.cfg", "mast_height_mm = 400\nmast_height_mm = 410\n"), &robot, &error));
  EXPECT_NE(error.find("given twice"), std::string::npos) << error;
  EXPECT_FALSE(ReadRobotFile(Write("r4.cfg", "mast_height_mm = 40cm\n"), &robot, &error));
  EXPECT_FALSE(ReadRobotFile(Write("r5.cfg", "mast_height_mm = 400\npan_sign = 2\n"), &robot, &error));
  EXPECT_FALSE(ReadRobotFile(Write("r6.cfg", "mast_height_mm = -400\n"), &robot, &error));
  EXPECT_TRUE(ReadRobotFile(Write("r7.cfg", "# a robot\nmast_height_mm = 380  # measured\n"), &robot, &error)) << error;
  EXPECT_EQ(robot.geometry.mast_height_mm, 380);
}

}  // namespace
}  // namespace objscan
