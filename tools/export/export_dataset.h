// Writing objscan dataset folders (LCM-free): the format drivers/camera's image-folder source reads.
//
//   DIR/images/NNNNNN.png  one lossless PNG per frame, NNNNNN = the frame's seq (6+ digits, zero padded), so the
//                          sorted file names are the frame order; gray frames stay gray, colour frames are BGR->PNG.
//   DIR/calib.yaml         OpenCV FileStorage: image_width, image_height, camera_matrix (3x3),
//                          distortion_coefficients (1x5, OpenCV order k1 k2 p1 p2 k3).
//   DIR/poses_gt.txt       TUM "t tx ty tz qx qy qz qw", camera-to-world (world_from_camera), t = utime / 1e6 s,
//                          positions in mm, first line "# units: mm"; one line per written frame that has a true pose
//                          (matched by seq), in frame order. Written only when at least one true pose was given.
//   DIR/timestamps.txt     "FILE_NAME UTIME_US" per written frame (the frame's utime), in frame order.
//   With video = true, a video folder instead of images/: DIR/video.avi (Motion-JPEG, quality 95, colour: gray
//   frames as BGR; the frames in seq order; a frame whose seq or utime does not increase is left out, counted) and timestamps.txt with
//   "FRAME_NUMBER UTIME_US" lines (frames numbered from 0).
//   DIR/odometry.txt       the odometry readings given, in time order (one per utime), with a header naming the
//                          columns and units. timestamps.txt, odometry.txt and robot.cfg: common/recorded_run.h.
// Numbers are written with 17 significant digits (t with 6 decimals, i.e. exact µs), so they read back exactly.
//
// Errors: functions return false with *error (a sentence naming the file) and never throw or exit.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <opencv2/videoio.hpp>
#include <set>
#include <string>
#include <vector>

#include "common/camera_model.h"
#include "common/sensor_data.h"
#include "common/tum.h"

namespace objscan {

struct DatasetWriterOptions {
  std::string out_dir;     // output folder (created with images/; files of the same name are overwritten)
  int every = 1;           // keep frames whose seq is a multiple of this (1 = all)
  int64_t max_frames = 0;  // write at most this many frames (0 = no limit)
  bool video = false;      // a video folder (video.avi) instead of images/
};

// Checks the options. False with *why on the first problem.
bool ValidateDatasetWriterOptions(const DatasetWriterOptions& options, std::string* why);

struct DatasetExportSummary {
  int64_t frames_offered = 0;            // decodable frames given to AddFrame
  int64_t frames_written = 0;            // PNG files written
  int64_t frames_not_selected = 0;       // skipped by --every or after --max-frames
  int64_t frames_duplicate_seq = 0;      // skipped because a frame with that seq was already written
  int64_t frames_out_of_order = 0;       // video only: skipped because seq or utime did not increase
  int64_t frames_undecodable = 0;        // counted by CountUndecodable (message did not decode to an image)
  int64_t frames_size_mismatch = 0;      // written frames whose size differs from the calibration
  int64_t calibration_changes = 0;       // calibrations that differ from the first one (calib.yaml keeps the first)
  int64_t true_poses_written = 0;        // lines in poses_gt.txt
  int64_t frames_without_true_pose = 0;  // written frames without a true pose (only when some true pose was given)
  int64_t odometry_written = 0;          // lines in odometry.txt
  int64_t odometry_repeated_time = 0;    // readings left out because an earlier one had the same utime
  bool has_calibration = false;          // calib.yaml written
};

// Collects frames, calibration, true poses and odometry and writes the dataset folder. Frames are written as they
// come (AddFrame); the text files are written by Finish(). Not thread-safe.
class DatasetWriter {
 public:
  // Validates the options and creates out_dir/images. False with *error.
  bool Open(const DatasetWriterOptions& options, std::string* error);

  enum class FrameResult { kWritten, kNotSelected, kDuplicateSeq, kError };
  // Writes the frame as images/<seq>.png when it is selected (seq % every == 0, limit not reached) and its seq is
  // new. kError (with *error) when the PNG cannot be written or the image is empty / not 8-bit 1 or 3 channels.
  FrameResult AddFrame(const ImageFrame& frame, std::string* error);
  // True when max_frames frames were written (later frames are not selected).
  bool LimitReached() const { return options_.max_frames > 0 && summary_.frames_written >= options_.max_frames; }
  // Counts a frame whose message could not be decoded (reason is logged by the caller).
  void CountUndecodable() { ++summary_.frames_undecodable; }
  // The first camera becomes calib.yaml; later ones only count as calibration_changes when they differ.
  void AddCamera(const PinholeCamera& camera);
  // A true pose (world_from_camera, mm) of frame pose.seq. The last one given for a seq wins.
  void AddTruePose(const CameraPoseEstimate& pose);
  void AddOdometry(const OdometryReading& reading);
  // Writes calib.yaml (when a camera was given), poses_gt.txt (when true poses were given) and odometry.txt (when
  // odometry was given). False with *error on a write failure.
  bool Finish(std::string* error);

  const DatasetExportSummary& summary() const { return summary_; }

 private:
  struct WrittenFrame {
    int64_t seq = 0;
    int64_t utime = 0;
    int width = 0, height = 0;
  };
  DatasetWriterOptions options_;
  DatasetExportSummary summary_;
  std::vector<WrittenFrame> written_;
  std::set<int64_t> written_seqs_;
  bool has_camera_ = false;
  PinholeCamera camera_;
  std::map<int64_t, CameraPoseEstimate> true_poses_;  // by seq
  std::vector<OdometryReading> odometry_;
  // Video: opened at the second frame (its rate from the first two frames' times); the first frame waits here.
  bool WriteVideoFrame(const ImageFrame& frame, std::string* error);
  std::unique_ptr<cv::VideoWriter> video_;
  ImageFrame first_video_frame_;
  cv::Size video_size_;
};

// Image file name of frame seq: 6 digits zero padded ("000042.png"); negative seqs are rejected by AddFrame.
std::string DatasetImageName(int64_t seq);

}  // namespace objscan
