// Reads the report's per-frame series from a session log (common/lcm_log.h): per CAMERA_IMAGE seq, the frame's utime,
// the live tracks of its FEATURE_TRACKS, and when FEATURE_TRACKS and CAMERA_POSE of that seq were logged after the
// image (logger receive times); and the true camera poses the driver published on GROUND_TRUTH_POSE (the simulator,
// or a dataset's poses_gt.txt such as Middlebury's calibration), stamped with their utime, into *truth (may be
// null). Messages that do not decode are skipped. False with *error when the log cannot be read; damage is reported
// in *damage ("" when none).
#pragma once

#include <string>

#include "tools/report/report.h"

namespace objscan {

bool ReadFrameSeries(const std::string& log_path, FrameSeries* frames, std::vector<StampedPose>* truth,
                     std::string* damage, std::string* error);

}  // namespace objscan
