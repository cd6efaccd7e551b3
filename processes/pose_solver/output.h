// File writers for the pose solver's results (LCM-free). All return false (with *error) when the file cannot be
// written; they never throw.
//  - TUM trajectory: "t tx ty tz qx qy qz qw" per line, t = utime / 1e6 s, camera-to-world (world_from_camera),
//    positions in MILLIMETRES (stated in the '#' header; evo users: --t_max_diff default is fine, scale with 1e-3).
//  - Landmarks PLY (ASCII): x y z (mm, world) float, red green blue uchar, nobs int, error float (px).
//  - COLMAP text model (cameras.txt PINHOLE or OPENCV, images.txt with cam_from_world quaternion qw qx qy qz and
//    translation, 2-D points with POINT3D_ID, points3D.txt with tracks), positions in mm.
#pragma once

#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "common/camera_model.h"
#include "common/sensor_data.h"
#include "processes/pose_solver/pose_estimator.h"

namespace objscan {

// True for the pose statuses the writers keep (tracking, relocalized): the frames that count as posed.
bool IsWrittenPose(PoseStatus status);

// Writes poses whose status is in `statuses` (default: tracking and relocalized) as TUM (common/tum.h; t from utime,
// positions with 4 decimals), under a header saying whether positions are mm or an arbitrary unit.
bool WriteTumTrajectory(const std::string& path, const std::vector<CameraPoseEstimate>& poses, std::string* error,
                        bool include_all_statuses = false);
// Header comments say whether positions are mm or an arbitrary unit (scale: the map's ScaleSource).
bool WriteLandmarksPly(const std::string& path, const std::vector<Landmark>& landmarks, ScaleSource scale,
                       std::string* error);

// One image of the COLMAP model: its pose and its 2-D observations (undistorted or raw pixels as measured).
struct ColmapImage {
  CameraPoseEstimate pose;
  std::string name;                      // image file name, e.g. "000012.png"
  std::vector<TrackedFeature> features;  // observations (track id = POINT3D_ID when a landmark has that id)
};
// Writes dir/cameras.txt, dir/images.txt, dir/points3D.txt (dir is created). Only images with a tracking or
// relocalized pose are written; point tracks list (IMAGE_ID, POINT2D_IDX) of those images.
bool WriteColmapText(const std::string& dir, const PinholeCamera& camera, const std::vector<ColmapImage>& images,
                     const std::vector<Landmark>& landmarks, std::string* error);
// The same with the images supplied one at a time (so that a long stream's observations need not be in memory):
// next_image(&image) fills the next image and returns true, false after the last one.
bool WriteColmapText(const std::string& dir, const PinholeCamera& camera,
                     const std::function<bool(ColmapImage*)>& next_image, const std::vector<Landmark>& landmarks,
                     std::string* error);

// Append-only binary file of frames' 2-D observations (track id, u, v), read back in the same order: keeps the
// observations of a long stream on disk until the COLMAP model is written at its end. Not thread-safe.
class ObservationSpool {
 public:
  // Creates (truncates) the file; ok() is false with error() set when it cannot.
  explicit ObservationSpool(const std::string& path);
  // Closes and removes the file.
  ~ObservationSpool();
  ObservationSpool(const ObservationSpool&) = delete;
  ObservationSpool& operator=(const ObservationSpool&) = delete;
  bool ok() const { return ok_; }
  const std::string& error() const { return error_; }
  // Appends one frame (seq and features; ages are not kept). False (and ok() false) on a write error.
  bool Append(const TrackFrame& frame);
  // Reads the frames back from the first; Next() then returns them in Append order and false after the last (or
  // on a read error, with ok() false).
  bool Rewind();
  bool Next(int64_t* seq, std::vector<TrackedFeature>* features);
  int64_t frames() const { return frames_; }

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
  bool ok_ = false;
  std::string error_;
  int64_t frames_ = 0;
};

}  // namespace objscan
