// Frame sources for the camera driver (LCM-free): image folders, Middlebury multi-view folders, video files and
// V4L2 devices behind one interface, plus the calibration / ground-truth readers they use.
//
// Units and frames: intrinsics in px (pixel (u, v) = (column, row), origin at the centre of the top-left pixel),
// ground-truth poses world_from_camera in mm (camera x right, y down, z forward). A source's "natural order" is
// the sorted file list (folders) or the order of the *_par.txt lines (Middlebury); frame numbers given by the user
// (--order, --rotate-180) are 1-based positions in that natural order, or file names.
//
// Errors: opening a source (OpenFrameSource) validates everything that can be validated up front (calibration,
// order list, file lists) and returns nullptr with a clear message; nothing here throws or exits. A single bad
// frame later (unreadable, odd-sized) is reported by Next() as kSkipped with a reason and the file name, and the
// source moves on to the following frame.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <opencv2/core.hpp>
#include <set>
#include <string>
#include <vector>

#include "common/camera_model.h"
#include "common/tum.h"

namespace objscan {

// The kind of a source path, detected from the file system (see DetectSourceKind).
enum class SourceKind { kImageFolder, kMiddlebury, kVideoFile, kV4l2Device };
const char* SourceKindName(SourceKind kind);

struct FrameSourceOptions {
  std::string path;                    // --source: folder, *_par.txt file / folder, video file, /dev/videoN or index
  std::string calib_path;              // --calib: OpenCV FileStorage calibration; overrides the source's own
  std::string order;                   // --order: "9,8,7" / "3-5" / file names; empty = natural order
  std::string rotate_180;              // --rotate-180: frames (natural 1-based numbers or names) to rotate 180 deg
  double gt_position_scale = 1000;     // ground-truth positions are multiplied by this (m -> mm by default)
  std::string camera_name = "camera";  // camera_name written into every frame's calibration
  int device_width = 0;                // V4L2 only: requested capture size in px (0 = the calibration's size)
  int device_height = 0;               // V4L2 only
};

// One frame as the source delivers it, already rotated when requested.
struct SourceFrame {
  cv::Mat image;               // CV_8UC1 (gray) or CV_8UC3 (BGR)
  PinholeCamera camera;        // intrinsics of this frame (per view for Middlebury, adjusted for rotation)
  bool has_true_pose = false;  // true when world_from_camera holds the dataset's true pose
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();  // mm, true pose (when has_true_pose)
  std::string name;          // file name, or "frame N" for video / device frames
  int64_t recorded_utime = -1;  // µs, the image's time from a folder's timestamps.txt, or for a video without
                                // one the container's presentation time (-1: none)
  int source_index = 0;      // 0-based index in the natural order (frame counter for video / device)
  bool rotated_180 = false;  // true when the image was rotated 180 deg in-plane
};

enum class ReadResult { kFrame, kSkipped, kEnd };

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // Reads the next frame. kFrame fills *frame. kSkipped: that frame is unusable, *reason is a short rejection
  // reason ("frame: unreadable file", "frame: wrong size") and *detail names the file; call Next() again for the
  // following frame. kEnd: no more frames (until Rewind()). May block (video decode, device capture).
  virtual ReadResult Next(SourceFrame* frame, std::string* reason, std::string* detail) = 0;
  // Starts again at the first frame (for --loop). False when the source cannot restart (live device).
  virtual bool Rewind() = 0;
  // Number of frames in one pass (after --order), or -1 when unknown (video, device).
  virtual int NumFrames() const = 0;
  // Frame rate the source reports (video file fps, device fps) in Hz, or 0 when it has none.
  virtual double SourceRate() const { return 0; }
  // True for live sources whose Next() blocks until the hardware delivers a frame (they set the pace).
  virtual bool IsLive() const { return false; }
  virtual SourceKind kind() const = 0;
  // One line for the start-up log: kind, path, frame count, image size.
  virtual std::string Describe() const = 0;
};

// Detects the kind of a source path: a directory containing *_par.txt or a *_par.txt file -> Middlebury; a
// directory with exactly one video file (IsVideoFileName), no images and no images/ -> video (a video folder:
// calib.yaml and a recorded run's files beside the video, common/recorded_run.h); another directory -> image
// folder; /dev/video* or a non-negative integer -> V4L2 device; another regular file -> video.
// Returns false with *error when the path does not exist.
bool DetectSourceKind(const std::string& path, SourceKind* kind, std::string* error);

// Opens the source described by options (kind detected from the path). Returns nullptr with *error on a missing
// or invalid calibration, an empty folder, a bad --order / --rotate-180 list, an unopenable video or device.
std::unique_ptr<FrameSource> OpenFrameSource(const FrameSourceOptions& options, std::string* error);

// ---- Building blocks (exposed for tests and tools) ----

// ReadCalibrationFile / WriteCalibrationFile (common/camera_model.h) read and write the calibration files.

// Reads a TUM file (common/tum.h: "t tx ty tz qx qy qz qw" per line, '#' comments, camera-to-world, non-unit
// quaternions and malformed lines are errors). Positions are multiplied by position_scale, except when a header
// comment says "# units: mm" (then taken as mm).
bool ReadTumTrajectory(const std::string& path, double position_scale, std::vector<StampedPose>* poses,
                       std::string* error);

// One view of a Middlebury *_par.txt: "name k11..k33 r11..r33 t1 t2 t3", x ~ K [R | t] X, X_cam = R X + t.
struct MiddleburyView {
  std::string image_name;
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();  // px
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // camera_from_world rotation as stored in the file
  Eigen::Vector3d t = Eigen::Vector3d::Zero();      // file units (metres for the Middlebury sets)
  // world_from_camera in mm: R orthonormalized (nearest rotation), position -R^T t times position_scale.
  Eigen::Isometry3d WorldFromCamera(double position_scale) const;
};
// Parses a *_par.txt file: first line the number of views, then one line per view. Rejects count mismatches,
// malformed numbers, K with a bad last row or non-positive focal lengths, R far from a rotation (|RR^T - I| > 1e-3).
bool ReadMiddleburyPar(const std::string& path, std::vector<MiddleburyView>* views, std::string* error);

// Parses a frame list ("9,8,7", "1-3,7", "a.png,b.png", whitespace allowed) against the natural-order names:
// numbers are 1-based positions, other tokens are file names (with or without extension). Returns 0-based indices
// in the listed order (duplicates kept) or false with *error naming the first bad token.
bool ParseFrameList(const std::string& text, const std::vector<std::string>& names, std::vector<int>* indices,
                    std::string* error);

// Rotates a frame 180 deg in-plane: pixel (u, v) -> (w-1-u, h-1-v). The camera turns by 180 deg about its z axis:
// cx' = w-1-cx, cy' = h-1-cy, p1' = -p1, p2' = -p2 (fx, fy, skew, k1, k2, k3 unchanged), and
// world_from_camera' = world_from_camera * Rz(180 deg). Projections stay consistent: a world point seen at (u, v)
// before is seen at (w-1-u, h-1-v) after.
PinholeCamera RotateCamera180(const PinholeCamera& camera);
Eigen::Isometry3d RotatePose180(const Eigen::Isometry3d& world_from_camera);
void RotateFrame180(SourceFrame* frame);

// True for the image file extensions the folder source reads (png jpg jpeg bmp ppm pgm tif tiff, any case).
bool IsImageFileName(const std::string& name);
// True for the video file extensions taken as the video of a folder (avi mp4 mkv mov webm m4v mpg mpeg, any case).
bool IsVideoFileName(const std::string& name);

}  // namespace objscan
