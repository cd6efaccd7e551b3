#include "tools/export/export_dataset.h"

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/core/persistence.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/recorded_run.h"

namespace objscan {
namespace fs = std::filesystem;

namespace {
bool Fail(std::string* error, const std::string& text) {
  if (error) *error = text;
  return false;
}

bool SameCamera(const PinholeCamera& a, const PinholeCamera& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy &&
         a.skew == b.skew && a.k1 == b.k1 && a.k2 == b.k2 && a.p1 == b.p1 && a.p2 == b.p2 && a.k3 == b.k3;
}

}  // namespace

bool ValidateDatasetWriterOptions(const DatasetWriterOptions& options, std::string* why) {
  if (options.out_dir.empty()) return Fail(why, "--out: the output folder is required");
  if (options.every < 1) return Fail(why, "--every must be >= 1");
  if (options.max_frames < 0) return Fail(why, "--max-frames must be >= 0 (0 = no limit)");
  return true;
}

std::string DatasetImageName(int64_t seq) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%06" PRId64 ".png", seq);
  return buf;
}

bool DatasetWriter::Open(const DatasetWriterOptions& options, std::string* error) {
  if (!ValidateDatasetWriterOptions(options, error)) return false;
  options_ = options;
  std::error_code ec;
  const fs::path dir = options.video ? fs::path(options.out_dir) : fs::path(options.out_dir) / "images";
  fs::create_directories(dir, ec);
  if (ec) return Fail(error, "cannot create " + dir.string() + ": " + ec.message());
  return true;
}

bool DatasetWriter::WriteVideoFrame(const ImageFrame& frame, std::string* error) {
  // Always colour: gray frames (and a log that mixes gray and colour) as BGR.
  cv::Mat bgr;
  if (frame.image.channels() == 1)
    cv::cvtColor(frame.image, bgr, cv::COLOR_GRAY2BGR);
  else
    bgr = frame.image;
  if (!video_ && first_video_frame_.image.empty()) {
    first_video_frame_ = frame;
    first_video_frame_.image = bgr.clone();
    return true;
  }
  if (!video_) {
    const double dt = (frame.utime - first_video_frame_.utime) * 1e-6;
    const double fps = dt > 0 && dt < 10 ? 1.0 / dt : 30.0;
    const std::string path = (fs::path(options_.out_dir) / "video.avi").string();
    video_ = std::make_unique<cv::VideoWriter>();
    const cv::Size size(first_video_frame_.image.cols, first_video_frame_.image.rows);
    try {
      if (!video_->open(path, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps, size, true))
        return Fail(error, "cannot write " + path);
      video_->set(cv::VIDEOWRITER_PROP_QUALITY, 95);
      video_->write(first_video_frame_.image);
    } catch (const cv::Exception& e) {
      return Fail(error, "cannot write " + path + ": " + e.what());
    }
    video_size_ = first_video_frame_.image.size();
    first_video_frame_.image.release();
  }
  if (bgr.size() != video_size_)
    return Fail(error, "frame " + std::to_string(frame.seq) + " is " + std::to_string(bgr.cols) + "x" +
                           std::to_string(bgr.rows) + ": a video's frames all have the first one's size");
  try {
    video_->write(bgr);
  } catch (const cv::Exception& e) {
    return Fail(error, "cannot write video.avi: " + std::string(e.what()));
  }
  return true;
}

DatasetWriter::FrameResult DatasetWriter::AddFrame(const ImageFrame& frame, std::string* error) {
  ++summary_.frames_offered;
  if (LimitReached() || frame.seq % options_.every != 0) {
    ++summary_.frames_not_selected;
    return FrameResult::kNotSelected;
  }
  if (frame.seq < 0) {
    Fail(error, "frame with negative seq " + std::to_string(frame.seq));
    return FrameResult::kError;
  }
  if (written_seqs_.count(frame.seq)) {
    ++summary_.frames_duplicate_seq;
    return FrameResult::kDuplicateSeq;
  }
  if (frame.image.empty() || (frame.image.type() != CV_8UC1 && frame.image.type() != CV_8UC3)) {
    Fail(error, "frame " + std::to_string(frame.seq) + ": image is empty or not 8-bit gray / BGR");
    return FrameResult::kError;
  }
  if (options_.video) {
    if (!written_.empty() && (frame.seq <= written_.back().seq || frame.utime <= written_.back().utime)) {
      ++summary_.frames_out_of_order;
      return FrameResult::kNotSelected;
    }
    written_.push_back({frame.seq, frame.utime, frame.image.cols, frame.image.rows});
    if (!WriteVideoFrame(frame, error)) {
      written_.pop_back();
      return FrameResult::kError;
    }
    written_seqs_.insert(frame.seq);
    ++summary_.frames_written;
    return FrameResult::kWritten;
  }
  const fs::path path = fs::path(options_.out_dir) / "images" / DatasetImageName(frame.seq);
  bool ok = false;
  try {
    ok = cv::imwrite(path.string(), frame.image);
  } catch (const cv::Exception& e) {
    Fail(error, "cannot write " + path.string() + ": " + e.what());
    return FrameResult::kError;
  }
  if (!ok) {
    Fail(error, "cannot write " + path.string());
    return FrameResult::kError;
  }
  written_seqs_.insert(frame.seq);
  written_.push_back({frame.seq, frame.utime, frame.image.cols, frame.image.rows});
  ++summary_.frames_written;
  return FrameResult::kWritten;
}

void DatasetWriter::AddCamera(const PinholeCamera& camera) {
  if (!has_camera_) {
    camera_ = camera;
    has_camera_ = true;
  } else if (!SameCamera(camera, camera_)) {
    ++summary_.calibration_changes;
  }
}

void DatasetWriter::AddTruePose(const CameraPoseEstimate& pose) { true_poses_[pose.seq] = pose; }

void DatasetWriter::AddOdometry(const OdometryReading& reading) { odometry_.push_back(reading); }

bool DatasetWriter::Finish(std::string* error) {
  const fs::path root(options_.out_dir);
  // Frames in file-name order (= seq order), as the folder reader sees them.
  std::vector<WrittenFrame> frames = written_;
  std::sort(frames.begin(), frames.end(), [](const WrittenFrame& a, const WrittenFrame& b) { return a.seq < b.seq; });

  summary_.frames_size_mismatch = 0;
  if (has_camera_) {
    for (const auto& f : frames)
      if (f.width != camera_.width || f.height != camera_.height) ++summary_.frames_size_mismatch;
    if (!WriteCalibrationFile((root / "calib.yaml").string(), camera_, error)) return false;
    summary_.has_calibration = true;
  }

  if (!true_poses_.empty()) {
    std::vector<StampedPose> lines;
    summary_.frames_without_true_pose = 0;
    for (const auto& f : frames) {
      const auto it = true_poses_.find(f.seq);
      if (it == true_poses_.end()) {
        ++summary_.frames_without_true_pose;
        continue;
      }
      StampedPose p;
      p.t = static_cast<double>(it->second.utime) / 1e6;
      p.world_from_camera = it->second.world_from_camera;
      lines.push_back(p);
    }
    if (!WriteTumTrajectory((root / "poses_gt.txt").string(), lines,
                       {"units: mm",
                        "objscan true camera poses (world_from_camera), t = utime / 1e6 s, one per image "
                        "in images/ that has one, in file-name order",
                        "t tx ty tz qx qy qz qw"},
                       error, -1))  // lossless: the folder replays the session exactly
      return false;
    summary_.true_poses_written = static_cast<int64_t>(lines.size());
  }

  // The image times, on the clock of the odometry: a recorded robot run replays with its odometry from them.
  std::vector<FrameTime> times;
  for (const auto& f : frames)
    times.push_back({options_.video ? std::to_string(times.size()) : DatasetImageName(f.seq), f.utime});
  if (options_.video) {
    if (video_) {
      video_->release();
    } else if (!first_video_frame_.image.empty()) {
      return Fail(error, "a video needs at least 2 frames (1 given)");
    }
  }
  if (!times.empty() && !WriteFrameTimes((root / kTimestampsFileName).string(), times, error)) return false;

  if (!odometry_.empty()) {
    std::vector<OdometryReading> readings = odometry_;
    std::stable_sort(readings.begin(), readings.end(),
                     [](const OdometryReading& a, const OdometryReading& b) { return a.utime < b.utime; });
    // odometry.txt's times increase: a second reading with the same time (a repeated message) is left out, counted.
    const auto last = std::unique(readings.begin(), readings.end(),
                                  [](const OdometryReading& a, const OdometryReading& b) { return a.utime == b.utime; });
    summary_.odometry_repeated_time = static_cast<int64_t>(readings.end() - last);
    readings.erase(last, readings.end());
    if (!WriteOdometryFile((root / kOdometryFileName).string(), readings, error)) return false;
    summary_.odometry_written = static_cast<int64_t>(readings.size());
  }
  return true;
}

}  // namespace objscan
