// object_finder: finds the object to model in the sparse map. LANDMARKS, CAMERA_POSE, CAMERA_INFO, ROBOT_ODOMETRY in,
// TARGET out.
#include "common/node_main.h"
#include "processes/object_finder/object_finder_node.h"

int main(int argc, char** argv) {
  return objscan::NodeMain<objscan::ObjectFinderNode>(
      argc, argv, "object_finder", "object finder: LANDMARKS + CAMERA_POSE + CAMERA_INFO in, TARGET out",
      objscan::AddObjectFinderNodeOptions, objscan::ValidateObjectFinderNodeOptions);
}
