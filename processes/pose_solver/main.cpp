// pose_solver: FEATURE_TRACKS + CAMERA_INFO + ROBOT_ODOMETRY in, CAMERA_POSE / LANDMARKS / CAMERA_POSE_FINAL out.
#include "common/node_main.h"
#include "processes/pose_solver/pose_solver_node.h"

int main(int argc, char** argv) {
  return objscan::NodeMain<objscan::PoseSolverNode>(
      argc, argv, "pose_solver",
      "camera poses and sparse landmarks from feature tracks (+ odometry): FEATURE_TRACKS in, CAMERA_POSE and "
      "LANDMARKS out",
      objscan::AddPoseSolverNodeOptions, objscan::ValidatePoseSolverNodeOptions);
}
