// objscan_replay: reruns the processing pipeline over a recorded log, deterministically (see pipeline_replay.h).
#include <cstdio>

#include "common/log.h"
#include "common/options.h"
#include "common/output_folder.h"
#include "tools/replay/pipeline_replay.h"

int main(int argc, char** argv) {
  objscan::SetLogName("objscan_replay");
  objscan::PipelineReplayOptions options;
  bool tracker_only = false;
  bool no_dense = false;
  objscan::OptionParser parser("objscan_replay",
                               "Reruns tracker, pose solver and dense modeler over an LCM log, deterministically.");
  parser.Add("log", &options.log_path, "input LCM log");
  parser.Add("out", &options.out_dir, "output folder (replay.lcmlog and the results)");
  parser.Add("tracker-only", &tracker_only, "run only the tracker");
  parser.Add("no-dense", &no_dense, "run tracker and pose solver, not the dense modeler");
  parser.Add("pose-model", &options.pose_model, "pose solver camera model: 6dof or 4dof");
  parser.Add("tracker-args", &options.tracker_args, "extra tracker options, e.g. \"--descriptor-tracking on\"");
  parser.Add("pose-solver-args", &options.pose_solver_args, "extra pose solver options (as on its command line)");
  parser.Add("dense-modeler-args", &options.dense_modeler_args,
             "extra dense modeler options, e.g. \"--ridge-smoothing-radius 6\"");
  int exit_code = 0;
  if (!objscan::ParseCommandLineOrExit(parser, argc, argv, &exit_code)) return exit_code;
  if (options.log_path.empty() || options.out_dir.empty()) {
    objscan::LogError("--log and --out are required");
    return 2;
  }
  std::string moved_to, error;
  if (!objscan::PrepareOutputFolder(options.out_dir, &moved_to, &error)) {  // never over an earlier output
    objscan::LogError(error);
    return 2;
  }
  if (!moved_to.empty())
    objscan::LogInfo(options.out_dir + " held an earlier output: moved it to " + moved_to);
  options.run_pose_solver = !tracker_only;
  options.run_dense_modeler = !tracker_only && !no_dense;
  objscan::PipelineReplayResult result;
  if (!objscan::RunPipelineReplay(options, &result, &error)) {
    objscan::LogError(error);
    return 1;
  }
  std::fprintf(stderr, "[objscan_replay] nodes %s: %lld log events, %lld fed, %lld messages out -> %s/replay.lcmlog\n",
               result.nodes.c_str(), static_cast<long long>(result.events_read),
               static_cast<long long>(result.events_fed), static_cast<long long>(result.messages_out),
               options.out_dir.c_str());
  if (!result.log_damage.empty()) {
    objscan::LogError("the log is damaged: " + result.log_damage +
                      "; the results cover the events that could be read (exit 3)");
    return 3;
  }
  return 0;
}
