#include "processes/dense_modeler/export.h"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace objscan {
namespace {

std::string TempDir() {
  const auto dir = std::filesystem::temp_directory_path() / ("dense_export_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir.string();
}

TEST(Export, VoxelPlyMeshPlyAndOctomap) {
  std::vector<CarvedVoxel> voxels;
  for (int i = 0; i < 5; ++i) {
    CarvedVoxel v;
    v.ijk = Eigen::Vector3i(i, -i, 3);
    v.votes = 10 + i;
    v.bgr = {{1, 2, static_cast<uint8_t>(i)}};
    voxels.push_back(v);
  }
  const std::string dir = TempDir();
  std::string error;
  ASSERT_TRUE(WriteVoxelPly(dir + "/v.ply", voxels, 2.0, ScaleSource::kOdometry, &error)) << error;
  std::ifstream f(dir + "/v.ply", std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string s = ss.str();
  const size_t end = s.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  EXPECT_NE(s.find("element vertex 5"), std::string::npos);
  EXPECT_NE(s.substr(0, end).find("comment scale: metric (mm, scale from the odometry)"), std::string::npos);
  EXPECT_EQ(s.size() - (end + 11), 5u * (12 + 3 + 8));
  float x0;
  std::memcpy(&x0, s.data() + end + 11 + (12 + 3 + 8), 4);  // second voxel x = (1 + 0.5) * 2
  EXPECT_FLOAT_EQ(x0, 3.0f);

  const TriangleMesh mesh = MeshFromVoxels(voxels, 2.0, 0);
  ASSERT_TRUE(WriteMeshPly(dir + "/m.ply", mesh, ScaleSource::kNone, &error)) << error;
  EXPECT_GT(std::filesystem::file_size(dir + "/m.ply"), 100u);
  {  // images only: the header must not claim mm
    std::ifstream m(dir + "/m.ply", std::ios::binary);
    std::string header((std::istreambuf_iterator<char>(m)), std::istreambuf_iterator<char>());
    header = header.substr(0, header.find("end_header"));
    EXPECT_NE(header.find("comment scale: arbitrary"), std::string::npos);
    EXPECT_NE(header.find("surface, arbitrary unit"), std::string::npos) << header;
  }

  ASSERT_TRUE(WriteOctomap(dir + "/m.bt", voxels, 2.0, &error)) << error;
  octomap::OcTree tree(dir + "/m.bt");
  EXPECT_NEAR(tree.getResolution(), 0.002, 1e-12);
  EXPECT_EQ(tree.getNumLeafNodes(), 5u);
  for (const CarvedVoxel& v : voxels) {
    const octomap::point3d p((v.ijk.x() + 0.5f) * 0.002f, (v.ijk.y() + 0.5f) * 0.002f, (v.ijk.z() + 0.5f) * 0.002f);
    octomap::OcTreeNode* node = tree.search(p);
    ASSERT_NE(node, nullptr);
    EXPECT_TRUE(tree.isNodeOccupied(node));
  }
  EXPECT_FALSE(WriteVoxelPly("/nonexistent_dir_xyz/v.ply", voxels, 2.0, ScaleSource::kOdometry, &error));
  EXPECT_FALSE(error.empty());
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace objscan
