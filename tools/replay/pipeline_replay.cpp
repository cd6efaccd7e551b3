#include "tools/replay/pipeline_replay.h"

#include <sys/stat.h>

#include <memory>
#include <sstream>
#include <vector>

#include "common/bus.h"
#include "common/lcm_log.h"
#include "common/log.h"
#include "common/options.h"
#include "objscan/control_t.hpp"
#include "processes/tracker/tracker_node.h"
#ifdef OBJSCAN_HAVE_POSE_SOLVER
#include "processes/pose_solver/pose_solver_node.h"
#endif
#ifdef OBJSCAN_HAVE_DENSE_MODELER
#include "processes/dense_modeler/dense_modeler_node.h"
#endif

namespace objscan {
namespace {

// The nodes' bus: delivers on memq and records every publication.
class RecordingBus final : public Bus {
 public:
  RecordingBus(Bus& delivery, Bus& recorder, int64_t* count)
      : delivery_(delivery), recorder_(recorder), count_(count) {}
  bool Publish(const std::string& channel, const void* data, int size) override {
    ++*count_;
    recorder_.Publish(channel, data, size);
    return delivery_.Publish(channel, data, size);
  }
  void Subscribe(const std::string& channel, RawHandler handler, int queue_capacity) override {
    delivery_.Subscribe(channel, std::move(handler), queue_capacity);
  }
  int Handle(int timeout_ms) override { return delivery_.Handle(timeout_ms); }
  std::string Describe() const override { return "replay(" + delivery_.Describe() + ")"; }
  bool IsNetwork() const override { return delivery_.IsNetwork(); }

 private:
  Bus& delivery_;
  Bus& recorder_;
  int64_t* count_;
};

// Applies "--name value ..." (split at white space) to the options that add_options registers; false with *error
// naming the node on an unknown option or a bad value.
template <typename NodeOptions, typename AddOptions>
bool ApplyNodeArgs(const std::string& node, const std::string& args, AddOptions add_options, NodeOptions* options,
                   std::string* error) {
  if (args.empty()) return true;
  OptionParser parser(node, "");
  add_options(parser, options);
  std::istringstream in(args);
  std::vector<std::string> words;
  for (std::string w; in >> w;) words.push_back(w);
  std::string why;
  if (!parser.ParseArgs(words, &why)) {
    *error = node + " options '" + args + "': " + why;
    return false;
  }
  return true;
}

}  // namespace

bool RunPipelineReplay(const PipelineReplayOptions& options, PipelineReplayResult* result, std::string* error) {
  mkdir(options.out_dir.c_str(), 0755);
  LcmLogReader log;
  if (!log.Open(options.log_path, error)) return false;
  try {
    auto memq = MakeLcmBus("memq://");
    auto recorder = MakeLcmBus("datalog://" + options.out_dir + "/replay.lcmlog");
    RecordingBus bus(*memq, *recorder, &result->messages_out);

    std::vector<std::unique_ptr<Node>> nodes;
    TrackerNodeOptions tracker_options;
    tracker_options.exit_when_finished = false;
    if (!ApplyNodeArgs("tracker", options.tracker_args, AddTrackerNodeOptions, &tracker_options, error)) return false;
    nodes.push_back(std::make_unique<TrackerNode>(bus, tracker_options));
    result->nodes = "tracker";
#ifdef OBJSCAN_HAVE_POSE_SOLVER
    if (options.run_pose_solver) {
      PoseSolverNodeOptions pose_options;
      pose_options.exit_when_finished = false;
      pose_options.output_dir = options.out_dir;
      pose_options.model = options.pose_model;
      if (!ApplyNodeArgs("pose_solver", options.pose_solver_args, AddPoseSolverNodeOptions, &pose_options, error))
        return false;
      std::string why;
      if (!ValidatePoseSolverNodeOptions(pose_options, &why)) {
        *error = "pose solver options: " + why;
        return false;
      }
      nodes.push_back(std::make_unique<PoseSolverNode>(bus, pose_options));
      result->nodes += ",pose_solver";
    }
#endif
#ifdef OBJSCAN_HAVE_DENSE_MODELER
    if (options.run_dense_modeler) {
      DenseModelerNodeOptions dense_options;
      dense_options.exit_when_finished = false;
      dense_options.output_dir = options.out_dir;
      if (!ApplyNodeArgs("dense_modeler", options.dense_modeler_args, AddDenseModelerNodeOptions, &dense_options,
                         error))
        return false;
      nodes.push_back(std::make_unique<DenseModelerNode>(bus, dense_options));
      result->nodes += ",dense_modeler";
    }
#endif
    LcmLogEvent event;
    while (log.Next(&event)) {
      ++result->events_read;
      const std::string& channel = event.channel;
      const bool feed = options.input_channels.count(channel) &&
                        (channel != "OBJSCAN_CONTROL" ||
                         IsDriverMessage(channel, event.data.data(), static_cast<int>(event.data.size())));
      if (feed) {
        ++result->events_fed;
        memq->Publish(channel, event.data.data(), static_cast<int>(event.data.size()));
        while (memq->Handle(0) > 0) {
        }
      }
    }
    result->log_damage = log.damage().Describe();
    for (auto& node : nodes) node->OnShutdown();
    while (memq->Handle(0) > 0) {
    }
  } catch (const std::exception& e) {
    *error = e.what();
    return false;
  }
  return true;
}

}  // namespace objscan
