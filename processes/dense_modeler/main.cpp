// dense_modeler: dense reconstruction process. CAMERA_IMAGE, CAMERA_INFO, FEATURE_TRACKS, CAMERA_POSE(_FINAL),
// TARGET, LANDMARKS in; VOXEL_MAP, MODEL (+ files in --output-dir) out.
#include "common/node_main.h"
#include "processes/dense_modeler/dense_modeler_node.h"

int main(int argc, char** argv) {
  return objscan::NodeMain<objscan::DenseModelerNode>(
      argc, argv, "dense_modeler", "dense modeler: posed images and tracks in, VOXEL_MAP and MODEL (files) out",
      objscan::AddDenseModelerNodeOptions, objscan::ValidateDenseModelerNodeOptions);
}
