// Deterministic replay of a recorded session through the processing nodes, in one process.
//
// The nodes (tracker, and pose solver / dense modeler when built) are the very classes the processes run; here
// they share one memq:// bus. Each input event of the log is published on that bus and every resulting message
// cascade is drained before the next event, so the output depends only on the log and the options — never on
// timing or machine load. What the nodes publish is written to OUT/replay.lcmlog (event time = the message's data
// time; PROCESS_STATUS left out: wall clock). Channels the nodes produce are not fed from the log (a session log
// holds the live run's outputs too), nor control messages other than END_OF_STREAM.
#pragma once

#include <cstdint>
#include <set>
#include <string>

namespace objscan {

struct PipelineReplayOptions {
  std::string log_path;  // input LCM log (e.g. DIR/session.lcmlog from objscan run)
  std::string out_dir;   // output folder: replay.lcmlog and the nodes' files
  std::set<std::string> input_channels = {"CAMERA_IMAGE",      "CAMERA_INFO",     "ROBOT_ODOMETRY",
                                          "GROUND_TRUTH_POSE", "OBJSCAN_CONTROL", "TARGET"};  // fed from the log
  bool run_pose_solver = true;      // include the pose solver when it is built
  bool run_dense_modeler = true;    // include the dense modeler when it is built
  std::string pose_model = "6dof";  // pose solver camera model: "6dof" or "4dof" (the robot's floor model)
  // Extra options of each node, as on its process's command line ("--name value ..." split at white space, e.g.
  // "--ridge-smoothing-radius 6"); applied after the replay's own settings. An unknown option fails the replay.
  std::string tracker_args;
  std::string pose_solver_args;
  std::string dense_modeler_args;
};

struct PipelineReplayResult {
  int64_t events_read = 0;   // events in the log
  int64_t events_fed = 0;    // events published to the nodes
  int64_t messages_out = 0;  // messages the nodes published (all channels)
  std::string nodes;         // names of the nodes that ran
  std::string log_damage;    // what of the log was skipped as damaged ("" when it was whole)
};

// Runs the replay. Blocks until the log is consumed. Returns false with *error when the log cannot be read or the
// output cannot be written (node construction errors are reported the same way).
bool RunPipelineReplay(const PipelineReplayOptions& options, PipelineReplayResult* result, std::string* error);

}  // namespace objscan
