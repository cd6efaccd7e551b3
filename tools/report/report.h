// The run report: one self-contained report.html per run folder (`objscan report DIR`, and at the end of every
// `objscan run`), readable in any browser without network: plots are inline SVG, pictures are PNG data URIs.
// Contents: status and figures, the trajectory from above (final, online, truth where there is one; Sim(3)-aligned
// to the truth when there is one), position error per frame, tracks per frame, stage latencies per frame, the model
// rendered from a few sides (PNGs made by the viewer headless), the summary. LCM-free: the session log's per-frame
// series come in through FrameSeries (report_log.h reads them).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "tools/evaluate/evaluation.h"

namespace objscan {

// Per camera frame, from the session log. Times are the logger's receive times, so latencies are what the bus saw.
struct FrameSeries {
  std::vector<double> t_s;               // s, the frame's own utime (data time)
  std::vector<int> tracks;               // live tracks in the frame (FEATURE_TRACKS), -1 when none arrived
  std::vector<double> tracks_latency_ms;  // ms, FEATURE_TRACKS logged after the CAMERA_IMAGE of the frame; NaN if none
  std::vector<double> pose_latency_ms;    // ms, CAMERA_POSE logged after the CAMERA_IMAGE of the frame; NaN if none
};

struct ReportInputs {
  std::string title;                         // e.g. the run folder
  std::string status;                        // summary.json "status" ("" when unknown)
  std::vector<StampedPose> final_poses;      // trajectory.txt (TUM, mm)
  std::vector<StampedPose> online_poses;     // trajectory_online.txt
  std::vector<StampedPose> truth;            // true poses (simulator, or a dataset's), empty when there are none
  std::string truth_source;                  // where they came from, shown in the report
  FrameSeries frames;
  // Figures from other tools (objscan_evaluate's "key value" lines), shown as tables: {caption, lines}.
  std::vector<std::pair<std::string, std::vector<std::pair<std::string, std::string>>>> figures;
  std::vector<std::pair<std::string, std::vector<uint8_t>>> pictures;  // {caption, PNG bytes}
  std::string summary_json;                  // shown as it is
  std::vector<std::string> missing;          // inputs that were not there, named in the report
};

// Trajectory figures computed for the report (Sim(3) to the truth, poses paired by time within 5 ms, as objscan_evaluate).
struct ReportTrajectoryFigures {
  bool aligned = false;
  double ate_rmse_mm = 0, ate_max_mm = 0, scale = 1, registered_fraction = 0;
  std::vector<double> t_s, error_mm;  // per matched pose
};
ReportTrajectoryFigures AlignForReport(const std::vector<StampedPose>& estimate, const std::vector<StampedPose>& truth,
                                       std::vector<StampedPose>* aligned);

std::string RenderReportHtml(const ReportInputs& in);

// Helpers, exposed for tests.
std::string Base64(const std::vector<uint8_t>& bytes);
std::string HtmlEscape(const std::string& text);

}  // namespace objscan
