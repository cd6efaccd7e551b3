// planner: drives the robot (ROBOT_COMMAND) to find the target, circle it and add views where the model is thin.
#include "common/node_main.h"
#include "processes/planner/planner_node.h"

int main(int argc, char** argv) {
  return objscan::NodeMain<objscan::PlannerNode>(
      argc, argv, "planner",
      "robot planner: CAMERA_POSE, ROBOT_ODOMETRY, TARGET, LANDMARKS, VOXEL_MAP, CAMERA_INFO in; ROBOT_COMMAND out",
      objscan::AddPlannerNodeOptions, objscan::ValidatePlannerNodeOptions);
}
