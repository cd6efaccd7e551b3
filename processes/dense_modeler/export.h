// Model files (LCM-free): voxel centres as PLY, the surface mesh as PLY, the voxels as an OctoMap .bt.
// PLY files are binary little endian with x y z as float (mm, world), colour as uchar red green blue.
// The OctoMap tree is in metres (OctoMap's convention; resolution = voxel size / 1000), every voxel centre marked
// occupied (voxel grid and octree grid coincide because both are aligned to the world origin).
// Functions return false with *error on I/O failure; they never throw.
#pragma once

#include <string>
#include <vector>

#include "common/sensor_data.h"
#include "processes/dense_modeler/marching_cubes.h"
#include "processes/dense_modeler/space_carving.h"

namespace objscan {

// Vertex properties: x y z (float, mm), red green blue (uchar), votes (int), views (int). The PLY header's comments
// say whether lengths are mm or an arbitrary unit (scale: the poses' ScaleSource, ScaleDescription's words).
bool WriteVoxelPly(const std::string& path, const std::vector<CarvedVoxel>& voxels, double voxel_size_mm,
                   ScaleSource scale, std::string* error);
// Vertex properties x y z red green blue, faces as uchar-count int lists; scale comments as WriteVoxelPly.
bool WriteMeshPly(const std::string& path, const TriangleMesh& mesh, ScaleSource scale, std::string* error);
bool WriteOctomap(const std::string& path, const std::vector<CarvedVoxel>& voxels, double voxel_size_mm,
                  std::string* error);

}  // namespace objscan
