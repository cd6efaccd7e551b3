#include "common/adapters.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace objscan {
namespace {

ImageFrame TestFrame() {
  ImageFrame f;
  f.utime = 123456;
  f.seq = 7;
  f.camera_name = "cam";
  f.image = cv::Mat(48, 64, CV_8UC3);
  for (int r = 0; r < f.image.rows; ++r)
    for (int c = 0; c < f.image.cols; ++c) f.image.at<cv::Vec3b>(r, c) = cv::Vec3b(r * 3, c * 2, (r + c) % 256);
  return f;
}

TEST(AdaptersTest, RawEncodingsRoundTrip) {
  const ImageFrame in = TestFrame();
  for (int8_t enc : {image_t::ENCODING_RGB8, image_t::ENCODING_BGR8}) {
    const image_t msg = ImageToMessage(in, enc);
    EXPECT_EQ(msg.size, 64 * 48 * 3);
    ImageFrame out;
    std::string error;
    ASSERT_TRUE(ImageFromMessage(msg, &out, &error)) << error;
    EXPECT_EQ(cv::norm(out.image, in.image, cv::NORM_INF), 0.0);
    EXPECT_EQ(out.seq, 7);
    EXPECT_EQ(out.utime, 123456);
  }
  const image_t gray = ImageToMessage(in, image_t::ENCODING_GRAY8);
  ImageFrame out;
  std::string error;
  ASSERT_TRUE(ImageFromMessage(gray, &out, &error));
  EXPECT_EQ(out.image.channels(), 1);
}

TEST(AdaptersTest, JpegRoundTripIsClose) {
  const ImageFrame in = TestFrame();
  const image_t msg = ImageToMessage(in, image_t::ENCODING_JPEG, 98);
  ImageFrame out;
  std::string error;
  ASSERT_TRUE(ImageFromMessage(msg, &out, &error)) << error;
  EXPECT_LT(cv::norm(out.image, in.image, cv::NORM_L1) / in.image.total() / 3, 4.0);
}

TEST(AdaptersTest, RejectsBadImages) {
  const ImageFrame in = TestFrame();
  std::string error;
  ImageFrame out;
  image_t truncated = ImageToMessage(in, image_t::ENCODING_RGB8);
  truncated.data.resize(100);
  truncated.size = 100;
  EXPECT_FALSE(ImageFromMessage(truncated, &out, &error));
  EXPECT_EQ(error, "image: truncated data");
  image_t unknown = ImageToMessage(in, image_t::ENCODING_RGB8);
  unknown.encoding = 42;
  EXPECT_FALSE(ImageFromMessage(unknown, &out, &error));
  EXPECT_EQ(error, "image: unknown encoding");
  EXPECT_FALSE(ImageFromMessage(ImageToMessage(in, image_t::ENCODING_RGB8), &out, &error, 640, 480));
  EXPECT_EQ(error, "image: wrong size");
  image_t bad_jpeg = ImageToMessage(in, image_t::ENCODING_JPEG);
  for (size_t i = 20; i < bad_jpeg.data.size(); ++i) bad_jpeg.data[i] = 0;
  bad_jpeg.data.resize(30);
  bad_jpeg.size = 30;
  EXPECT_FALSE(ImageFromMessage(bad_jpeg, &out, &error));
  image_t size_mismatch = ImageToMessage(in, image_t::ENCODING_RGB8);
  size_mismatch.size = 5;
  EXPECT_FALSE(ImageFromMessage(size_mismatch, &out, &error));
}

TEST(AdaptersTest, TracksValidation) {
  TrackFrame f;
  f.seq = 3;
  f.features = {{1, 10.5f, 20.25f, 0}, {2, 30.f, 40.f, 5}};
  feature_tracks_t msg = TracksToMessage(f);
  TrackFrame out;
  std::string error;
  ASSERT_TRUE(TracksFromMessage(msg, &out, &error));
  ASSERT_EQ(out.features.size(), 2u);
  EXPECT_FLOAT_EQ(out.features[0].v, 20.25f);
  feature_tracks_t dup = msg;
  dup.track_id[1] = 1;
  EXPECT_FALSE(TracksFromMessage(dup, &out, &error));
  EXPECT_EQ(error, "tracks: duplicate id");
  feature_tracks_t nan = msg;
  nan.u[0] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_FALSE(TracksFromMessage(nan, &out, &error));
  feature_tracks_t mismatch = msg;
  mismatch.num_tracks = 3;
  EXPECT_FALSE(TracksFromMessage(mismatch, &out, &error));
}

TEST(AdaptersTest, PoseRoundTripAndValidation) {
  CameraPoseEstimate p;
  p.seq = 9;
  p.world_from_camera.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  p.world_from_camera.translation() = Eigen::Vector3d(100, -200, 400);
  p.status = PoseStatus::kTracking;
  const pose_t msg = PoseToMessage(p);
  CameraPoseEstimate out;
  std::string error;
  ASSERT_TRUE(PoseFromMessage(msg, &out, &error));
  EXPECT_TRUE(out.world_from_camera.isApprox(p.world_from_camera, 1e-12));
  pose_t bad = msg;
  bad.orientation[0] = 2;
  EXPECT_FALSE(PoseFromMessage(bad, &out, &error));
  bad = msg;
  bad.position_mm[1] = std::nan("");
  EXPECT_FALSE(PoseFromMessage(bad, &out, &error));
}

TEST(AdaptersTest, CameraInfoRoundTripAndValidation) {
  PinholeCamera c;
  c.name = "sim";
  c.width = 640;
  c.height = 480;
  c.fx = c.fy = 800;
  c.cx = 319.5;
  c.cy = 239.5;
  c.k1 = -0.1;
  PinholeCamera out;
  std::string error;
  ASSERT_TRUE(CameraFromMessage(CameraToMessage(c, 5), &out, &error));
  EXPECT_DOUBLE_EQ(out.k1, -0.1);
  camera_info_t bad = CameraToMessage(c, 5);
  bad.fx = 0;
  EXPECT_FALSE(CameraFromMessage(bad, &out, &error));
}

}  // namespace
}  // namespace objscan
