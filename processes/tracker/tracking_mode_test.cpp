#include "processes/tracker/tracking_mode.h"

#include <cmath>
#include <cstdlib>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "processes/tracker/synthetic_sequence.h"

namespace objscan {
namespace {

using testing_support::SyntheticSequence;

std::vector<cv::Mat> Sequence(double shift_px, double angle_rad, double scale, int frames) {
  SyntheticSequence seq(640, 480, 200, 7);
  std::vector<cv::Mat> out;
  for (int k = 0; k < frames; ++k)
    out.push_back(seq.Render(seq.Motion(k * shift_px, 0.3 * k * shift_px, k * angle_rad, std::pow(scale, k)), 1.0, k));
  return out;
}

TEST(TrackingModeTest, VideoRateStepsKeepKlt) {
  TrackingModeProbe p = ProbeTrackingMode(Sequence(3.0, 0.01, 1.005, 6));
  EXPECT_EQ(p.pairs, 5);
  EXPECT_GT(p.median_kept, 0.8) << p.detail;
  EXPECT_FALSE(p.wide_baseline) << p.detail;
  EXPECT_NEAR(p.median_flow_px, 3.0, 2.0) << p.detail;
}

TEST(TrackingModeTest, LargeStepsChooseDescriptors) {
  // 25 deg in-plane turn, 25 % zoom and 90 px per frame: far beyond a KLT window and its pyramid.
  TrackingModeProbe p = ProbeTrackingMode(Sequence(90.0, 0.44, 1.25, 6));
  EXPECT_EQ(p.pairs, 5);
  EXPECT_LT(p.median_kept, 0.5) << p.detail;
  EXPECT_TRUE(p.wide_baseline) << p.detail;
}

TEST(TrackingModeTest, UnrelatedImagesChooseDescriptors) {
  std::vector<cv::Mat> frames;
  for (int k = 0; k < 4; ++k) {
    SyntheticSequence seq(320, 240, 50, 100 + k);
    frames.push_back(seq.Render(seq.Motion(0, 0, 0, 1)));
  }
  TrackingModeProbe p = ProbeTrackingMode(frames);
  EXPECT_TRUE(p.wide_baseline) << p.detail;
  EXPECT_LT(p.median_kept, 0.2) << p.detail;
}

TEST(TrackingModeTest, TooFewOrBadFramesDoNotThrow) {
  TrackingModeProbe none = ProbeTrackingMode({});
  EXPECT_EQ(none.pairs, 0);
  EXPECT_FALSE(none.wide_baseline);
  std::vector<cv::Mat> frames = Sequence(3.0, 0.0, 1.0, 3);
  frames[1] = cv::Mat();  // unreadable frame in the middle
  TrackingModeProbe p = ProbeTrackingMode(frames);
  EXPECT_EQ(p.pairs, 2);
  EXPECT_EQ(p.median_kept, 0.0) << p.detail;
}

// The real sparse rings (16 views, 22.5 deg apart) and the Oxford turntable (10 deg) nobody here made.
TEST(TrackingModeTest, RealWideBaselineSetsChooseDescriptors) {
  const char* dir = std::getenv("OBJSCAN_DATA_DIR");
  if (!dir || !*dir) GTEST_SKIP() << "OBJSCAN_DATA_DIR not set: real image sets not available";
  struct Set { std::string first; int count; int digits; int start; };
  const Set sets[] = {{"middlebury_templeSparseRing/templeSR", 6, 4, 1},
                      {"middlebury_dinoSparseRing/dinoSR", 6, 4, 1},
                      {"oxford_dinosaur/viff.", 6, 3, 0}};
  for (const Set& s : sets) {
    std::vector<cv::Mat> frames;
    for (int k = 0; k < s.count; ++k) {
      std::string n = std::to_string(s.start + k);
      n = std::string(s.digits - n.size(), '0') + n;
      cv::Mat image = cv::imread(std::string(dir) + "/" + s.first + n + ".png", cv::IMREAD_GRAYSCALE);
      if (image.empty()) GTEST_SKIP() << "missing " << s.first << n << ".png";
      frames.push_back(image);
    }
    TrackingModeProbe p = ProbeTrackingMode(frames);
    EXPECT_TRUE(p.wide_baseline) << s.first << ": " << p.detail;
  }
}

}  // namespace
}  // namespace objscan
