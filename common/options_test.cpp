#include "common/options.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>

namespace objscan {
namespace {

struct Fixture {
  std::string url = "memq://";
  int frames = 10;
  double rate = 30.0;
  bool realtime = true;
  int64_t seed = 1;
  OptionParser parser{"prog", "test program"};
  Fixture() {
    parser.Add("lcm-url", &url, "bus URL");
    parser.Add("frames", &frames, "frames");
    parser.Add("rate", &rate, "Hz");
    parser.Add("realtime", &realtime, "wall-clock pacing");
    parser.Add("seed", &seed, "seed");
  }
};

TEST(OptionsTest, ParsesBothForms) {
  Fixture f;
  std::string error;
  ASSERT_TRUE(f.parser.ParseArgs({"--frames", "42", "--rate=15.5", "--realtime=false", "--seed", "7", "pos"}, &error))
      << error;
  EXPECT_EQ(f.frames, 42);
  EXPECT_DOUBLE_EQ(f.rate, 15.5);
  EXPECT_FALSE(f.realtime);
  EXPECT_EQ(f.seed, 7);
  EXPECT_EQ(f.parser.positional(), std::vector<std::string>{"pos"});
}

TEST(OptionsTest, FlagWithoutValueMeansTrue) {
  Fixture f;
  f.realtime = false;
  std::string error;
  ASSERT_TRUE(f.parser.ParseArgs({"--realtime"}, &error));
  EXPECT_TRUE(f.realtime);
}

TEST(OptionsTest, RejectsUnknownAndMalformed) {
  Fixture f;
  std::string error;
  EXPECT_FALSE(f.parser.ParseArgs({"--nope", "1"}, &error));
  EXPECT_NE(error.find("unknown option"), std::string::npos);
  Fixture g;
  EXPECT_FALSE(g.parser.ParseArgs({"--frames", "12x"}, &error));
  EXPECT_NE(error.find("bad value"), std::string::npos);
  Fixture h;
  EXPECT_FALSE(h.parser.ParseArgs({"--frames"}, &error));
  EXPECT_NE(error.find("needs a value"), std::string::npos);
}

TEST(OptionsTest, FileThenCommandLineWins) {
  const std::string path = ::testing::TempDir() + "objscan_options_test_" + std::to_string(getpid());
  {
    std::ofstream out(path);
    out << "# comment\nframes = 99\nrate: 5\nrealtime false\n";
  }
  Fixture f;
  std::string error;
  ASSERT_TRUE(f.parser.ParseArgs({"--rate", "7", "--options-file", path}, &error)) << error;
  EXPECT_EQ(f.frames, 99);
  EXPECT_DOUBLE_EQ(f.rate, 7.0);
  EXPECT_FALSE(f.realtime);
  std::remove(path.c_str());
  Fixture g;
  EXPECT_FALSE(g.parser.ParseArgs({"--options-file", "/nonexistent/file"}, &error));
}

TEST(OptionsTest, UsageAndEffectiveListEveryOption) {
  Fixture f;
  const std::string usage = f.parser.Usage();
  const std::string effective = f.parser.Effective();
  for (const char* name : {"lcm-url", "frames", "rate", "realtime", "seed"}) {
    EXPECT_NE(usage.find(name), std::string::npos) << name;
    EXPECT_NE(effective.find(name), std::string::npos) << name;
  }
  EXPECT_NE(effective.find("frames = 10"), std::string::npos);
}

TEST(OptionsTest, ChannelsAreRenamedByTheirDefaultName) {
  std::string poses = "CAMERA_POSE", odometry = "ROBOT_ODOMETRY", status = "PROCESS_STATUS";
  OptionParser parser("prog", "test program");
  parser.AddChannel(&poses, "input camera poses (pose_t)");
  parser.AddChannel(&odometry, "input odometry (\"\" = none)");
  parser.AddChannel(&status, "status out");
  const std::string usage = parser.Usage();
  EXPECT_NE(usage.find("--channel DEFAULT=NAME"), std::string::npos) << usage;
  EXPECT_NE(usage.find("CAMERA_POSE: input camera poses (pose_t)"), std::string::npos) << usage;
  EXPECT_EQ(usage.find("--camera-pose-channel"), std::string::npos);
  std::string error;
  ASSERT_TRUE(parser.ParseArgs({"--channel", "CAMERA_POSE=ROBOT2_POSE", "--channel=ROBOT_ODOMETRY="}, &error)) << error;
  EXPECT_EQ(poses, "ROBOT2_POSE");
  EXPECT_EQ(odometry, "");  // an empty name turns the input off
  EXPECT_EQ(status, "PROCESS_STATUS");
  EXPECT_NE(parser.Effective().find("channel CAMERA_POSE = ROBOT2_POSE"), std::string::npos) << parser.Effective();
  // An unknown channel, or no '=', is an error that lists the channels.
  EXPECT_FALSE(parser.ParseArgs({"--channel", "CAMERA_IMAGE=X"}, &error));
  EXPECT_NE(error.find("CAMERA_POSE ROBOT_ODOMETRY PROCESS_STATUS"), std::string::npos) << error;
  EXPECT_FALSE(parser.ParseArgs({"--channel", "CAMERA_POSE"}, &error));
  EXPECT_FALSE(parser.ParseArgs({"--channel", "=X"}, &error));
  // In an options file too.
  const std::string path = ::testing::TempDir() + "objscan_channel_test_" + std::to_string(getpid());
  {
    std::ofstream out(path);
    out << "channel = PROCESS_STATUS=STATUS_2\n";
  }
  ASSERT_TRUE(parser.ParseArgs({"--options-file", path}, &error)) << error;
  EXPECT_EQ(status, "STATUS_2");
  std::remove(path.c_str());
}

}  // namespace
TEST(ParseFiniteNumberTest, WholeFiniteNumbersOnly) {
  double v = -1;
  EXPECT_TRUE(ParseFiniteNumber("2.5", &v));
  EXPECT_EQ(v, 2.5);
  EXPECT_TRUE(ParseFiniteNumber("-1e-3", &v));
  EXPECT_EQ(v, -1e-3);
  for (const char* bad : {"", "2mm", "abc", "nan", "inf", " 1", "1 "}) {
    v = 7;
    EXPECT_FALSE(ParseFiniteNumber(bad, &v)) << bad;
    EXPECT_EQ(v, 7) << bad;  // untouched
  }
}

// Number lists (--radii, --roi-box, robot_sim's --blank and --orbit-center, scene vectors): an empty field anywhere is
// an error, a trailing comma included (std::getline dropped it: "80,20," was taken as 80,20).
TEST(ParseNumberListTest, EveryFieldANumber) {
  std::vector<double> v;
  EXPECT_TRUE(ParseNumberList("500,650.5,-1e3", &v));
  EXPECT_EQ(v, (std::vector<double>{500, 650.5, -1e3}));
  EXPECT_TRUE(ParseNumberList("7", &v));
  EXPECT_EQ(v, std::vector<double>{7});
  EXPECT_TRUE(ParseNumberList(" -100, -100 ,0", &v));
  EXPECT_EQ(v, (std::vector<double>{-100, -100, 0}));
  for (const char* bad : {"", ",", " ", "1,", ",1", "1,,2", "1,2,", "1, ,2", "1;2", "1 2", "1,nan", "a,b"}) {
    v = {9};
    EXPECT_FALSE(ParseNumberList(bad, &v)) << bad;
    EXPECT_TRUE(v.empty()) << bad;
  }
}

}  // namespace objscan
