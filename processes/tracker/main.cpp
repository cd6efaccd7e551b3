// tracker: KLT feature tracker process. CAMERA_IMAGE (+ optional CAMERA_INFO) in, FEATURE_TRACKS out.
#include "common/node_main.h"
#include "processes/tracker/tracker_node.h"

int main(int argc, char** argv) {
  return objscan::NodeMain<objscan::TrackerNode>(argc, argv, "tracker",
                                                 "KLT feature tracker: CAMERA_IMAGE in, FEATURE_TRACKS out",
                                                 objscan::AddTrackerNodeOptions, objscan::ValidateTrackerNodeOptions);
}
