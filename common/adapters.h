// Message <-> struct conversion, with validation. Functions returning bool fill *error with a short reason
// ("image: wrong size") suitable as a rejection reason, and never throw.
#pragma once

#include <string>

#include "common/camera_model.h"
#include "common/sensor_data.h"
#include "objscan/camera_info_t.hpp"
#include "objscan/control_t.hpp"
#include "objscan/feature_tracks_t.hpp"
#include "objscan/image_t.hpp"
#include "objscan/odometry_t.hpp"
#include "objscan/pose_t.hpp"

namespace objscan {

// Decodes an image message into a gray or BGR cv::Mat (deep copy). Rejects unknown encodings, sizes that do not
// match the data, bad strides, undecodable JPEG. When expected_width/height > 0, also rejects other sizes.
bool ImageFromMessage(const image_t& msg, ImageFrame* out, std::string* error, int expected_width = 0,
                      int expected_height = 0);
// Encodes gray/BGR images as GRAY8 / RGB8 / BGR8 (raw) or JPEG (quality 1..100).
image_t ImageToMessage(const ImageFrame& frame, int8_t encoding, int jpeg_quality = 95);

bool CameraFromMessage(const camera_info_t& msg, PinholeCamera* out, std::string* error);
camera_info_t CameraToMessage(const PinholeCamera& camera, int64_t utime);

// Rejects array length mismatches, non-finite coordinates and duplicate ids.
bool TracksFromMessage(const feature_tracks_t& msg, TrackFrame* out, std::string* error);
feature_tracks_t TracksToMessage(const TrackFrame& frame);

bool OdometryFromMessage(const odometry_t& msg, OdometryReading* out, std::string* error);
odometry_t OdometryToMessage(const OdometryReading& reading);

// The To...Message functions leave session_id 0: a driver stamps its session on what it publishes (StampSession).
// Stamps a driver's session id (StatusReporter::AcceptSession) on the types that carry one; others stay as they are.
inline void StampSession(image_t* m, int64_t session_id) { m->session_id = session_id; }
inline void StampSession(camera_info_t* m, int64_t session_id) { m->session_id = session_id; }
inline void StampSession(odometry_t* m, int64_t session_id) { m->session_id = session_id; }
inline void StampSession(control_t* m, int64_t session_id) { m->session_id = session_id; }
template <class Msg>
void StampSession(Msg*, int64_t) {}

// Rejects non-finite values and non-unit quaternions.
bool PoseFromMessage(const pose_t& msg, CameraPoseEstimate* out, std::string* error);
pose_t PoseToMessage(const CameraPoseEstimate& pose, const std::string& parent_frame = "world",
                     const std::string& child_frame = "camera");

}  // namespace objscan
