#include "common/ply.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <fstream>

namespace objscan {
namespace {

std::string Temp(const std::string& name) { return ::testing::TempDir() + "objscan_ply_" + std::to_string(getpid()) + name; }

TEST(PlyTest, ReadsAsciiAndBinaryPoints) {
  {
    std::ofstream a(Temp("a.ply"));
    a << "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
         "property uchar red\nend_header\n1 2 3 255\n4 5 6 0\n";
    std::ofstream b(Temp("b.ply"), std::ios::binary);
    b << "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty uchar flag\nproperty double x\n"
         "property double y\nproperty double z\nend_header\n";
    const unsigned char flag = 1;
    const double xyz[3] = {7.5, -8, 9};
    b.write(reinterpret_cast<const char*>(&flag), 1);
    b.write(reinterpret_cast<const char*>(xyz), sizeof(xyz));
  }
  std::vector<Eigen::Vector3d> p;
  std::string error;
  ASSERT_TRUE(ReadPlyPoints(Temp("a.ply"), &p, &error)) << error;
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p[1], Eigen::Vector3d(4, 5, 6));
  ASSERT_TRUE(ReadPlyPoints(Temp("b.ply"), &p, &error)) << error;
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p[0], Eigen::Vector3d(7.5, -8, 9));
  EXPECT_FALSE(ReadPlyPoints(Temp("missing.ply"), &p, &error));
  std::remove(Temp("a.ply").c_str());
  std::remove(Temp("b.ply").c_str());
}

TEST(PlyTest, ReadsAsciiAndBinaryMeshes) {
  const std::string ascii = Temp("mesh_ascii.ply"), binary = Temp("mesh_bin.ply"), bad = Temp("mesh_bad.ply");
  {
    std::ofstream f(ascii);
    f << "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
         "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
  }
  {
    std::ofstream f(binary, std::ios::binary);
    f << "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
         "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    const float xyz[9] = {0, 0, 0, 2, 0, 0, 0, 2, 0};
    f.write(reinterpret_cast<const char*>(xyz), sizeof(xyz));
    const uint8_t n = 3;
    const int32_t idx[3] = {0, 1, 2};
    f.write(reinterpret_cast<const char*>(&n), 1);
    f.write(reinterpret_cast<const char*>(idx), sizeof(idx));
  }
  {
    std::ofstream f(bad);
    f << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
         "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n3 0 1 9\n";
  }
  std::vector<Eigen::Vector3d> v;
  std::vector<Eigen::Vector3i> t;
  std::string error;
  ASSERT_TRUE(ReadPlyMesh(ascii, &v, &t, &error)) << error;
  EXPECT_EQ(v.size(), 4u);
  ASSERT_EQ(t.size(), 2u);  // the quad, fanned
  EXPECT_EQ(t[1], Eigen::Vector3i(0, 2, 3));
  ASSERT_TRUE(ReadPlyMesh(binary, &v, &t, &error)) << error;
  ASSERT_EQ(t.size(), 1u);
  EXPECT_EQ(v[1], Eigen::Vector3d(2, 0, 0));
  EXPECT_FALSE(ReadPlyMesh(bad, &v, &t, &error));
  EXPECT_NE(error.find("out of range"), std::string::npos) << error;
  EXPECT_FALSE(ReadPlyMesh(Temp("missing.ply"), &v, &t, &error));
  // A point cloud has no faces.
  std::vector<Eigen::Vector3d> points;
  {
    std::ofstream f(bad);
    f << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
         "end_header\n0 0 0\n";
  }
  EXPECT_TRUE(ReadPlyPoints(bad, &points, &error));
  EXPECT_FALSE(ReadPlyMesh(bad, &v, &t, &error));
  EXPECT_NE(error.find("no face"), std::string::npos) << error;
  for (const auto& p : {ascii, binary, bad}) std::remove(p.c_str());
}

// Other programs' files: another element before the vertices, normals and a list among the vertex properties, a
// face property after the index list; a truncated binary file and a forged list length fail with a message.
TEST(PlyTest, OtherElementsAndPropertiesAreSkippedAndBadDataFails) {
  PlyData ply;
  std::string error;
  ASSERT_TRUE(ParsePly("ply\nformat ascii 1.0\ncomment x\nelement camera 1\nproperty float f\n"
                       "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\n"
                       "property float ny\nproperty float nz\nproperty list uchar int tags\nelement face 1\n"
                       "property list uchar int vertex_indices\nproperty uchar flags\nend_header\n800\n"
                       "0 0 0 0 0 1 2 7 8\n1 0 0 0 0 1 0\n0 1 0 0 0 1 1 5\n3 0 1 2 9\n",
                       &ply, &error)) << error;
  ASSERT_EQ(ply.points.size(), 3u);
  EXPECT_EQ(ply.points[2], Eigen::Vector3d(0, 1, 0));
  ASSERT_TRUE(ply.has_normals);
  EXPECT_EQ(ply.normals[1], Eigen::Vector3d(0, 0, 1));
  ASSERT_TRUE(ply.has_faces);
  ASSERT_EQ(ply.triangles.size(), 1u);
  EXPECT_EQ(ply.triangles[0], Eigen::Vector3i(0, 1, 2));

  std::string binary = "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                       "property float z\nend_header\n";
  const float xyz[4] = {1, 2, 3, 4};  // 1.33 vertices
  binary.append(reinterpret_cast<const char*>(xyz), sizeof(xyz));
  EXPECT_FALSE(ParsePly(binary, &ply, &error));
  EXPECT_NE(error.find("truncated"), std::string::npos) << error;
  EXPECT_FALSE(ParsePly("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                        "property float z\nelement face 1\nproperty list int int vertex_indices\nend_header\n"
                        "0 0 0\n2000000000 0 0 0\n",
                        &ply, &error));
  EXPECT_NE(error.find("list length"), std::string::npos) << error;
  EXPECT_FALSE(ParsePly("ply\nformat binary_big_endian 1.0\nelement vertex 0\nend_header\n", &ply, &error));
  EXPECT_FALSE(ParsePly("not a ply", &ply, &error));
  EXPECT_FALSE(ParsePly("ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n",
                        &ply, &error));
  EXPECT_NE(error.find("no vertex element"), std::string::npos) << error;
}

}  // namespace
}  // namespace objscan
