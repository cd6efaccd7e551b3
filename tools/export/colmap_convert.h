// COLMAP text-model helpers (LCM-free): reading images.txt into a TUM camera-to-world trajectory, and the
// ImageReader camera flags for a known calibration (so COLMAP can run as a peer baseline on an objscan dataset).
//
// images.txt (COLMAP 3.x): '#' comment lines, then two lines per image:
//   IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME     (q, t = cam_from_world: X_cam = R(q) X_world + t)
//   X Y POINT3D_ID ...                               (2-D observations; may be an empty line)
// Errors: functions return false with *error (file:line and the problem) and never throw or exit.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "common/camera_model.h"
#include "tools/export/export_dataset.h"

namespace objscan {

struct ColmapImage {
  int64_t image_id = 0;
  Eigen::Quaterniond camera_from_world_rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d camera_from_world_translation = Eigen::Vector3d::Zero();  // model units (arbitrary scale)
  int64_t camera_id = 0;
  std::string name;          // image path relative to the image folder, as COLMAP stores it
  int num_observations = 0;  // 2-D points listed
  int num_triangulated = 0;  // of them with POINT3D_ID != -1
};

// Parses images.txt. Rejects malformed pose lines (too few fields, bad numbers, zero quaternion) and observation
// lines whose token count is not a multiple of 3. The observation line may be missing for the last image.
bool ReadColmapImagesTxt(const std::string& path, std::vector<ColmapImage>* images, std::string* error);

// Frame index from an image name: the last run of digits in the file name without directory and extension
// ("images/000042.png" -> 42, "templeSR0007.png" -> 7). False when the stem holds no digits.
bool FrameIndexFromName(const std::string& name, int64_t* index);

// Converts registered images to TUM poses world_from_camera (R^T, -R^T t) with t = frame index / rate_hz s,
// sorted by t. Fails on a name without a frame index, a duplicate index or rate_hz <= 0.
bool ColmapImagesToTum(const std::vector<ColmapImage>& images, double rate_hz, std::vector<StampedPose>* poses,
                       std::string* error);

// COLMAP ImageReader.camera_model / camera_params for a calibration: PINHOLE "fx,fy,cx,cy" without distortion,
// OPENCV "fx,fy,cx,cy,k1,k2,p1,p2" with k3 = 0, FULL_OPENCV "fx,fy,cx,cy,k1,k2,p1,p2,k3,0,0,0" otherwise.
// COLMAP's principal point is in its own pixel convention (origin at the top-left corner of the top-left pixel),
// so cx + 0.5, cy + 0.5 are written (objscan: origin at the pixel centre). Fails on a non-zero skew.
bool ColmapCameraFromCalibration(const PinholeCamera& camera, std::string* model, std::string* params,
                                 std::string* error);

}  // namespace objscan
