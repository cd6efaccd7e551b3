#include "processes/tracker/tracker_node.h"

#include <gtest/gtest.h>

#include <limits>

#include <algorithm>
#include <cmath>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <vector>

#include "common/adapters.h"
#include "common/bus.h"
#include "common/options.h"
#include "objscan/feature_tracks_t.hpp"
#include "objscan/process_status_t.hpp"
#include "processes/tracker/synthetic_sequence.h"

namespace objscan {
namespace {

using testing_support::SyntheticSequence;

constexpr int kW = 320, kH = 240;

class TrackerNodeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    bus_ = MakeLcmBus("memq://");
    bus_->SubscribeMessage<feature_tracks_t>(
        "FEATURE_TRACKS", [this](const feature_tracks_t& m, const RawMessage&) { tracks_.push_back(m); });
    bus_->SubscribeMessage<control_t>("OBJSCAN_CONTROL", [this](const control_t& m, const RawMessage&) {
      if (m.command == control_t::COMMAND_FINISHED) finished_.push_back(m);
    });
    bus_->SubscribeMessage<process_status_t>(
        "PROCESS_STATUS", [this](const process_status_t& m, const RawMessage&) { statuses_.push_back(m); });
    options_.tracker.max_tracks = 300;
    options_.tracker.grid_cols = 8;
    options_.tracker.grid_rows = 6;
  }

  void Start() { node_ = std::make_unique<TrackerNode>(*bus_, options_); }
  void Drain() {
    while (bus_->Handle(0) > 0) {
    }
  }
  image_t Frame(int64_t seq, int8_t encoding = image_t::ENCODING_GRAY8) {
    ImageFrame f;
    f.seq = seq;
    f.utime = static_cast<int64_t>(std::llround(seq * 1e6 / 30.0));
    f.camera_name = "sim";
    f.image = seq_.Render(seq_.Motion(0.7 * seq, 0.3 * seq, 0, 1));
    if (encoding == image_t::ENCODING_BGR8 || encoding == image_t::ENCODING_JPEG)
      cv::cvtColor(f.image, f.image, cv::COLOR_GRAY2BGR);
    return ImageToMessage(f, encoding, 95);
  }
  void Publish(const image_t& msg) { ASSERT_TRUE(bus_->PublishMessage("CAMERA_IMAGE", msg)); }
  void PublishInfo(int width, int height) {
    PinholeCamera camera;
    camera.name = "sim";
    camera.width = width;
    camera.height = height;
    camera.fx = camera.fy = 300;
    camera.cx = width / 2.0;
    camera.cy = height / 2.0;
    ASSERT_TRUE(bus_->PublishMessage("CAMERA_INFO", CameraToMessage(camera, 0)));
  }
  void EndOfStream(int64_t last_seq, int64_t session_id = 0) {
    control_t c;
    c.session_id = session_id;
    c.utime = 0;
    c.sender = "robot_sim";
    c.target = "*";
    c.command = control_t::COMMAND_END_OF_STREAM;
    c.last_seq = last_seq;
    ASSERT_TRUE(bus_->PublishMessage("OBJSCAN_CONTROL", c));
  }
  // Publishes a good frame and checks that it is tracked with continuing tracks.
  void ExpectTracked(int64_t seq) {
    const size_t before = tracks_.size();
    Publish(Frame(seq));
    Drain();
    ASSERT_EQ(tracks_.size(), before + 1) << "seq " << seq;
    const feature_tracks_t& t = tracks_.back();
    EXPECT_EQ(t.seq, seq);
    EXPECT_GT(t.num_tracks, 100);
    if (before > 0) {
      int continued = 0;
      for (int32_t age : t.age) continued += age > 0;
      EXPECT_GT(continued, t.num_tracks * 8 / 10) << "tracking must continue over rejected frames";
    }
  }

  SyntheticSequence seq_{kW, kH, 32, 5};
  std::unique_ptr<Bus> bus_;
  TrackerNodeOptions options_;
  std::unique_ptr<TrackerNode> node_;
  std::vector<feature_tracks_t> tracks_;
  std::vector<control_t> finished_;
  std::vector<process_status_t> statuses_;
};

TEST_F(TrackerNodeTest, TracksFramesAndAnswersEndOfStream) {
  Start();
  PublishInfo(kW, kH);
  for (int64_t s = 0; s < 5; ++s) Publish(Frame(s, s % 2 ? image_t::ENCODING_BGR8 : image_t::ENCODING_GRAY8));
  Publish(Frame(5, image_t::ENCODING_RGB8));
  Publish(Frame(6, image_t::ENCODING_JPEG));
  Drain();
  ASSERT_EQ(tracks_.size(), 7u);
  for (size_t i = 0; i < tracks_.size(); ++i) {
    const feature_tracks_t& t = tracks_[i];
    EXPECT_EQ(t.seq, static_cast<int64_t>(i));
    EXPECT_EQ(t.utime, static_cast<int64_t>(std::llround(i * 1e6 / 30.0)));
    EXPECT_EQ(t.camera_name, "sim");
    EXPECT_EQ(t.image_width, kW);
    EXPECT_EQ(t.image_height, kH);
    EXPECT_GT(t.num_tracks, 250);
    EXPECT_LE(t.num_tracks, 300);
    TrackFrame decoded;
    std::string error;
    EXPECT_TRUE(TracksFromMessage(t, &decoded, &error)) << error;
  }
  // Most tracks of frame 0 are still alive in frame 6 (also through RGB and JPEG input).
  EXPECT_GT(tracks_.back().num_tracks, 250);
  int old = 0;
  for (int32_t age : tracks_.back().age) old += age == 6;
  EXPECT_GT(old, 200);
  EXPECT_EQ(node_->status().value("live_tracks"), tracks_.back().num_tracks);
  EXPECT_GE(node_->status().value("track_ms"), 0.0);
  EXPECT_EQ(node_->status().rejected_total(), 0);
  EXPECT_EQ(node_->status().messages_out(), 7);
  EXPECT_FALSE(node_->Finished());

  EndOfStream(6);
  Drain();
  ASSERT_EQ(finished_.size(), 1u);
  EXPECT_EQ(finished_[0].sender, "tracker");
  EXPECT_EQ(finished_[0].last_seq, 6);
  EXPECT_EQ(finished_[0].utime, tracks_.back().utime);
  EXPECT_TRUE(node_->Finished());
  EXPECT_EQ(node_->status().state(), +process_status_t::STATE_FINISHED);
  // A repeated end of stream is not answered twice.
  EndOfStream(6);
  Drain();
  EXPECT_EQ(finished_.size(), 1u);
  // Status published with the values.
  ASSERT_FALSE(statuses_.empty());
  const process_status_t& st = statuses_.back();
  EXPECT_EQ(st.name, "tracker");
  EXPECT_EQ(st.state, +process_status_t::STATE_FINISHED);
  std::vector<std::string> names(st.value_name.begin(), st.value_name.end());
  for (const char* n : {"live_tracks", "new_tracks", "lost_tracks", "track_ms"})
    EXPECT_NE(std::find(names.begin(), names.end(), n), names.end()) << n;
}

// A tracker restarted mid-session (its first frame has seq > 0) gives ids its predecessor cannot have given.
TEST_F(TrackerNodeTest, ATrackerJoiningAStreamUnderWayGivesIdsAboveAnyEarlierOnes) {
  Start();
  PublishInfo(kW, kH);
  for (int64_t s = 0; s < 3; ++s) Publish(Frame(s));
  Drain();
  ASSERT_EQ(tracks_.size(), 3u);
  int64_t earlier_max = 0;
  for (const auto& t : tracks_)
    for (int64_t id : t.track_id) earlier_max = std::max(earlier_max, id);
  EXPECT_LT(earlier_max, 1000);  // from seq 0: ids 0, 1, 2, ...
  // The restarted tracker: a new process (a new node on a new bus), first frame 40.
  node_.reset();
  tracks_.clear();
  SetUp();
  Start();
  PublishInfo(kW, kH);
  Publish(Frame(40));
  Publish(Frame(41));
  Drain();
  ASSERT_EQ(tracks_.size(), 2u);
  for (const auto& t : tracks_)
    for (int64_t id : t.track_id) EXPECT_GE(id, int64_t{40} << 32);
}

TEST_F(TrackerNodeTest, EndOfStreamWithoutExitKeepsRunning) {
  options_.exit_when_finished = false;
  Start();
  EndOfStream(-1);
  Drain();
  ASSERT_EQ(finished_.size(), 1u);
  EXPECT_EQ(finished_[0].last_seq, -1);
  EXPECT_TRUE(node_->end_of_stream_answered());
  EXPECT_FALSE(node_->Finished());
}

TEST_F(TrackerNodeTest, EndOfStreamForAnotherProcessIsIgnored) {
  Start();
  control_t c;
  c.session_id = 0;
  c.sender = "robot_sim";
  c.target = "pose_solver";
  c.command = control_t::COMMAND_END_OF_STREAM;
  c.last_seq = 3;
  ASSERT_TRUE(bus_->PublishMessage("OBJSCAN_CONTROL", c));
  Drain();
  EXPECT_TRUE(finished_.empty());
  EXPECT_FALSE(node_->Finished());
}

// A second session on the bus (another robot, a log replayed onto a live bus): its frames carry another session id
// and are refused, even with the very next seqs, and tracking goes on with this session's frames.
TEST_F(TrackerNodeTest, RefusesTheFramesOfAnotherSession) {
  Start();
  auto stamped = [this](int64_t seq, int64_t session) {
    image_t m = Frame(seq);
    StampSession(&m, session);
    return m;
  };
  Publish(stamped(0, 0xAAAA));
  Drain();
  ASSERT_EQ(tracks_.size(), 1u);
  for (int64_t seq = 1; seq <= 6; ++seq) {
    Publish(stamped(seq, 0xBBBB));  // the intruder's frame, then ours with the same seq
    Publish(stamped(seq, 0xAAAA));
  }
  Drain();
  const auto& st = node_->status();
  EXPECT_EQ(st.rejected("image: foreign session"), 6);
  EXPECT_EQ(st.rejected("image: out of order or repeated"), 0);  // never taken in, never in the seq stream
  ASSERT_EQ(tracks_.size(), 7u);
  for (int64_t seq = 0; seq <= 6; ++seq) EXPECT_EQ(tracks_[static_cast<size_t>(seq)].seq, seq);
  int continued = 0;
  for (int32_t age : tracks_.back().age) continued += age > 0;
  EXPECT_GT(continued, tracks_.back().num_tracks * 8 / 10);
  EXPECT_EQ(st.session_id(), 0xAAAA);
  // The other session's end of stream does not end this one's; its own does.
  EndOfStream(6, 0xBBBB);
  Drain();
  EXPECT_TRUE(finished_.empty());
  EXPECT_EQ(st.rejected("control: foreign session"), 1);
  EndOfStream(6, 0xAAAA);
  Drain();
  ASSERT_EQ(finished_.size(), 1u);
  EXPECT_EQ(finished_[0].session_id, 0xAAAA);  // its FINISHED carries the session it keeps to
}

TEST_F(TrackerNodeTest, RejectsEachKindOfBadImageAndKeepsTracking) {
  Start();
  ExpectTracked(0);
  const auto& st = node_->status();

  image_t wrong_size = Frame(1);
  {
    ImageFrame f;
    f.seq = 1;
    f.image = cv::Mat(kH / 2, kW / 2, CV_8UC1, cv::Scalar(90));
    wrong_size = ImageToMessage(f, image_t::ENCODING_GRAY8);
  }
  Publish(wrong_size);
  Drain();
  EXPECT_EQ(st.rejected("image: wrong size"), 1);
  ExpectTracked(2);

  image_t unknown = Frame(3);
  unknown.encoding = 42;
  Publish(unknown);
  Drain();
  EXPECT_EQ(st.rejected("image: unknown encoding"), 1);
  ExpectTracked(4);

  image_t truncated = Frame(5);
  truncated.data.resize(truncated.data.size() / 2);
  truncated.size = static_cast<int32_t>(truncated.data.size());  // consistent size field, too few rows
  Publish(truncated);
  Drain();
  EXPECT_EQ(st.rejected("image: truncated data"), 1);
  ExpectTracked(7);  // seq 6 never came: one dropped input

  image_t jpeg = Frame(8, image_t::ENCODING_JPEG);
  for (size_t i = 0; i < jpeg.data.size(); ++i) jpeg.data[i] = static_cast<uint8_t>(i * 7);  // garbage
  Publish(jpeg);
  Drain();
  EXPECT_EQ(st.rejected("image: undecodable jpeg"), 1);
  ExpectTracked(9);

  Publish(Frame(9));  // repeated
  Publish(Frame(4));  // out of order
  Drain();
  EXPECT_EQ(st.rejected("image: out of order or repeated"), 2);
  EXPECT_EQ(tracks_.back().seq, 9);
  ExpectTracked(10);

  const std::vector<uint8_t> garbage = {1, 2, 3, 4, 5, 6, 7};
  ASSERT_TRUE(bus_->Publish("CAMERA_IMAGE", garbage.data(), static_cast<int>(garbage.size())));
  Drain();
  EXPECT_EQ(st.rejected("image: malformed"), 1);
  ExpectTracked(11);

  EXPECT_EQ(st.dropped_inputs(), 1);
  ExpectTracked(15);  // 12, 13, 14 missing
  EXPECT_EQ(st.dropped_inputs(), 4);

  Publish(Frame(std::numeric_limits<int64_t>::max()));  // one forged seq must not block the stream
  Drain();
  EXPECT_EQ(st.rejected("image: implausible seq jump"), 1);
  EXPECT_EQ(st.dropped_inputs(), 4);
  ExpectTracked(16);

  EXPECT_EQ(st.rejected_total(), 8);
  // Every input counted: 9 good frames tracked + 8 rejected.
  EXPECT_EQ(st.messages_in(), 9 + 8);
  EXPECT_EQ(st.messages_out(), 9);
  EXPECT_FALSE(node_->Finished());

  EndOfStream(16);
  Drain();
  ASSERT_EQ(finished_.size(), 1u);
  EXPECT_EQ(finished_[0].last_seq, 16);

  node_->OnShutdown();  // forces a status publication
  Drain();
  ASSERT_FALSE(statuses_.empty());
  const process_status_t& s = statuses_.back();
  EXPECT_EQ(s.messages_rejected, 8);
  EXPECT_EQ(s.dropped_inputs, 4);
  EXPECT_EQ(s.num_rejection_reasons, 7);
}

TEST_F(TrackerNodeTest, ImageSizeComesFromCameraInfo) {
  Start();
  PublishInfo(kW * 2, kH * 2);  // calibration says 640x480
  Publish(Frame(0));            // 320x240
  Drain();
  EXPECT_TRUE(tracks_.empty());
  EXPECT_EQ(node_->status().rejected("image: wrong size"), 1);
  PublishInfo(kW, kH);
  Drain();
  ExpectTracked(1);
  // Bad camera_info is rejected and changes nothing.
  PinholeCamera bad;
  bad.width = -5;
  ASSERT_TRUE(bus_->PublishMessage("CAMERA_INFO", CameraToMessage(bad, 0)));
  const std::vector<uint8_t> garbage = {9, 9, 9};
  ASSERT_TRUE(bus_->Publish("CAMERA_INFO", garbage.data(), 3));
  Drain();
  EXPECT_EQ(node_->status().rejected("camera_info: invalid intrinsics"), 1);
  EXPECT_EQ(node_->status().rejected("camera_info: malformed"), 1);
  ExpectTracked(2);
}

TEST_F(TrackerNodeTest, FirstFrameFixesSizeWithoutCameraInfo) {
  options_.info_channel = "";
  Start();
  PublishInfo(kW * 2, kH * 2);  // ignored
  Drain();
  ExpectTracked(0);
  ImageFrame f;
  f.seq = 1;
  f.image = cv::Mat(kH, kW + 2, CV_8UC1, cv::Scalar(90));
  Publish(ImageToMessage(f, image_t::ENCODING_GRAY8));
  Drain();
  EXPECT_EQ(node_->status().rejected("image: wrong size"), 1);
  ExpectTracked(2);
}

TEST_F(TrackerNodeTest, SameInputGivesIdenticalOutput) {
  auto run = [this]() {
    auto bus = MakeLcmBus("memq://");
    std::vector<std::vector<uint8_t>> out;
    bus->Subscribe("FEATURE_TRACKS", [&out](const RawMessage& raw) {
      const auto* p = static_cast<const uint8_t*>(raw.data);
      out.emplace_back(p, p + raw.size);
    });
    TrackerNode node(*bus, options_);
    for (int64_t s = 0; s < 6; ++s) bus->PublishMessage("CAMERA_IMAGE", Frame(s));
    while (bus->Handle(0) > 0) {
    }
    return out;
  };
  const auto a = run(), b = run();
  ASSERT_EQ(a.size(), 6u);
  EXPECT_EQ(a, b);
}

TEST(TrackerNodeOptionsTest, ValidationAndParsing) {
  TrackerNodeOptions o;
  std::string why;
  EXPECT_TRUE(ValidateTrackerNodeOptions(o, &why)) << why;
  OptionParser parser("tracker", "test");
  AddTrackerNodeOptions(parser, &o);
  ASSERT_TRUE(parser.ParseArgs({"--image-queue-capacity", "5", "--threads", "2"}, &why)) << why;
  EXPECT_EQ(o.image_queue_capacity, 5);
  EXPECT_EQ(o.tracker.threads, 2);
  TrackerNodeOptions bad = o;
  bad.image_queue_capacity = 0;
  EXPECT_FALSE(ValidateTrackerNodeOptions(bad, &why));
  bad = o;
  bad.tracker.win_size = 14;
  EXPECT_FALSE(ValidateTrackerNodeOptions(bad, &why));
  EXPECT_NE(why.find("win_size"), std::string::npos) << why;
  auto bus = MakeLcmBus("memq://");
  EXPECT_THROW(TrackerNode(*bus, bad), std::invalid_argument);
}

}  // namespace
}  // namespace objscan
