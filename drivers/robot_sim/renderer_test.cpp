#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <opencv2/imgproc.hpp>

#include "common/robot_model.h"
#include "drivers/robot_sim/renderer.h"
#include "drivers/robot_sim/robot_sim.h"
#include "drivers/robot_sim/scene.h"

namespace objscan {
namespace {

PinholeCamera DefaultCamera() {
  PinholeCamera camera;
  camera.name = "sim";
  camera.width = 640;
  camera.height = 480;
  camera.fx = camera.fy = 800;
  camera.cx = 319.5;
  camera.cy = 239.5;
  return camera;
}

std::string ScenePath(const std::string& name) { return std::string(OBJSCAN_ROBOT_SIM_SCENES_DIR) + "/" + name; }

// Camera on the default robot at orbit radius 800 mm around the origin, aimed at `look_at`.
Eigen::Isometry3d OrbitView(double angle_deg, const Eigen::Vector3d& look_at, double radius = 800) {
  RobotGeometry geometry;
  const double a = angle_deg * M_PI / 180.0;
  const double x = radius * std::cos(a), y = radius * std::sin(a), theta = a + M_PI / 2;
  double pan = 0, tilt = 0;
  AimHead(geometry, x, y, theta, look_at, &pan, &tilt);
  return WorldFromCamera(geometry, x, y, theta, pan, tilt);
}

TEST(SceneTest, LoadsAllShippedScenes) {
  for (const char* name : {"sphere.scene", "box.scene", "cylinder.scene", "mesh.scene", "cluttered.scene"}) {
    const Scene scene = LoadScene(ScenePath(name));
    ASSERT_GE(scene.target_index, 0) << name;
    EXPECT_NE(scene.target().type, ShapeType::kFloor);
    EXPECT_NEAR(scene.target().bounds.min().z(), 0.0, 0.6) << name << ": target rests on the floor";
    EXPECT_FALSE(scene.Describe().empty());
  }
  const Scene sphere = LoadScene(ScenePath("sphere.scene"));
  EXPECT_EQ(sphere.target().type, ShapeType::kSphere);
  EXPECT_NEAR(sphere.target().radius_mm, 100, 1e-9);
  EXPECT_LT(sphere.TargetCenter().norm() - 100, 1e-6);
  for (const auto& o : sphere.objects) {
    if (o.is_target || o.type == ShapeType::kFloor) continue;
    const Eigen::Vector3d c = o.bounds.center();
    EXPECT_GE(std::hypot(c.x(), c.y()), 600) << o.name;
  }
}

TEST(SceneTest, RejectsBadDescriptions) {
  EXPECT_THROW(ParseScene("sphere center=0,0,100 radius=-1\n", "."), std::runtime_error);
  EXPECT_THROW(ParseScene("sphere center=0,0,100 colour=1\n", "."), std::runtime_error);
  EXPECT_THROW(ParseScene("teapot center=0,0,0\n", "."), std::runtime_error);
  EXPECT_THROW(ParseScene("sphere center=0,0\n", "."), std::runtime_error);
  EXPECT_THROW(ParseScene("sphere center=0,0,100 target=true\nbox center=0,0,0 target=true\n", "."),
               std::runtime_error);
  EXPECT_THROW(ParseScene("floor\n", "."), std::runtime_error);  // no object
  EXPECT_THROW(ParseScene("mesh file=/nonexistent.ply center=0,0,0\n", "."), std::runtime_error);
  EXPECT_THROW(ParseScene("sphere center=0,0,100 texture_size=1000\n", "."), std::exception);
  const Scene ok = ParseScene("# comment\nsphere center=0,0,50 radius=50  # trailing\nbox center=500,0,50\n", ".");
  EXPECT_EQ(ok.objects.size(), 2u);
  EXPECT_EQ(ok.target_index, 0);  // first object when none is marked
}

TEST(SceneTest, MeshFormatsLoadTheSameMesh) {
  // A unit cube as OBJ (quads, negative indices) and as ascii / binary PLY written by WritePly.
  const std::string dir = ::testing::TempDir();
  std::vector<Eigen::Vector3f> v = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                    {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  std::vector<Eigen::Vector3i> f = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                                    {1, 2, 6}, {1, 6, 5}, {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};
  ASSERT_TRUE(WritePly(dir + "/cube_a.ply", v, {}, f, true));
  ASSERT_TRUE(WritePly(dir + "/cube_b.ply", v, {}, f, false));
  {
    std::ofstream obj(dir + "/cube.obj");
    for (const auto& p : v) obj << "v " << p.x() << " " << p.y() << " " << p.z() << "\n";
    obj << "vt 0 0\nvn 0 0 1\n";
    for (const auto& t : f) obj << "f " << t.x() + 1 << "/1/1 " << t.y() + 1 << "//1 " << t.z() - 8 << "\n";
  }
  RawMesh a, b, c;
  std::string error;
  ASSERT_TRUE(LoadMeshFile(dir + "/cube_a.ply", &a, &error)) << error;
  ASSERT_TRUE(LoadMeshFile(dir + "/cube_b.ply", &b, &error)) << error;
  ASSERT_TRUE(LoadMeshFile(dir + "/cube.obj", &c, &error)) << error;
  for (const RawMesh* m : {&a, &b, &c}) {
    ASSERT_EQ(m->positions.size(), 8u);
    ASSERT_EQ(m->triangles.size(), 12u);
    for (size_t i = 0; i < 8; ++i) EXPECT_LT((m->positions[i] - v[i].cast<double>()).norm(), 1e-6);
    for (size_t i = 0; i < 12; ++i) EXPECT_EQ(m->triangles[i], f[i]);
  }
  {
    std::ofstream bad(dir + "/bad.obj");
    bad << "v 0 0 0\nv 1 0 0\nf 1 2 7\n";
  }
  EXPECT_FALSE(LoadMeshFile(dir + "/bad.obj", &a, &error));
  EXPECT_FALSE(LoadMeshFile(dir + "/missing.ply", &a, &error));
  // The cube as a scene object (scale 200: a 200 mm cube on the floor).
  const Scene scene = ParseScene("mesh file=cube_b.ply scale=200 center=0,0,0 target=true\n", dir);
  EXPECT_LT((scene.target().bounds.min() - Eigen::Vector3d(-100, -100, 0)).norm(), 1e-3);
  EXPECT_LT((scene.target().bounds.max() - Eigen::Vector3d(100, 100, 200)).norm(), 1e-3);
}

TEST(SceneTest, SurfaceSamplesLieOnTheSurfaceWithTheRequestedDensity) {
  const Scene scene = ParseScene(
      "sphere center=0,0,100 radius=100 target=true\nbox center=500,0,50 size=100,200,100 yaw=30\n"
      "cylinder center=-500,0,100 radius=50 height=200\n",
      ".");
  const auto sphere = SampleSurface(scene.objects[0], 1.0, 7);
  EXPECT_NEAR(static_cast<double>(sphere.size()), 4 * M_PI * 100 * 100, 1500);
  for (const auto& s : sphere) {
    EXPECT_NEAR((s.position.cast<double>() - Eigen::Vector3d(0, 0, 100)).norm(), 100, 1e-3);
    EXPECT_GT(s.normal.dot((s.position - Eigen::Vector3f(0, 0, 100)).normalized()), 0.999f);
  }
  const auto box = SampleSurface(scene.objects[1], 1.0, 7);  // bottom face (on the floor) is left out
  EXPECT_NEAR(static_cast<double>(box.size()), 2 * (100 * 200 + 100 * 100 + 200 * 100) - 100 * 200, 800);
  for (const auto& s : box) EXPECT_GT(s.position.z(), 0.4f);
  const auto cylinder = SampleSurface(scene.objects[2], 1.0, 7);
  EXPECT_NEAR(static_cast<double>(cylinder.size()), 2 * M_PI * 50 * 200 + M_PI * 50 * 50, 800);
  // determinism
  const auto again = SampleSurface(scene.objects[0], 1.0, 7);
  ASSERT_EQ(again.size(), sphere.size());
  EXPECT_EQ(again[10].position, sphere[10].position);
}

TEST(RendererTest, SphereDepthMatchesRaySphereIntersection) {
  const Scene scene = LoadScene(ScenePath("sphere.scene"));
  Renderer renderer(scene);
  const PinholeCamera camera = DefaultCamera();
  const Eigen::Vector3d centre(0, 0, 100);
  const double radius = 100;
  for (double angle : {-90.0, 30.0}) {
    const Eigen::Isometry3d world_from_camera = OrbitView(angle, centre);
    RenderOutput out;
    renderer.Render(camera, world_from_camera, &out);
    const Eigen::Vector3d origin = world_from_camera.translation();
    int checked = 0;
    double max_error = 0;
    for (int v = 0; v < camera.height; ++v) {
      for (int u = 0; u < camera.width; ++u) {
        if (out.object_id.at<int32_t>(v, u) != scene.target_index) continue;
        const Eigen::Vector3d ray_c((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0);
        const Eigen::Vector3d dir = world_from_camera.linear() * ray_c.normalized();
        const Eigen::Vector3d oc = origin - centre;
        const double b = oc.dot(dir), c = oc.squaredNorm() - radius * radius, disc = b * b - c;
        ASSERT_GT(disc, -1.0) << "pixel shows the sphere but the ray misses it: " << u << "," << v;
        if (disc <= 0) continue;
        const double t = -b - std::sqrt(disc);
        const Eigen::Vector3d hit = origin + t * dir;
        const Eigen::Vector3d normal = (hit - centre) / radius;
        if (-normal.dot(dir) < 0.3) continue;  // grazing rays: the tessellation error is amplified
        const double z_true = t * ray_c.normalized().z();
        max_error = std::max(max_error, std::abs(out.depth_mm.at<float>(v, u) - z_true));
        ++checked;
      }
    }
    std::printf("view %.0f deg: max |depth - analytic| = %.4f mm over %d sphere pixels\n", angle, max_error, checked);
    EXPECT_GT(checked, 15000);
    EXPECT_LT(max_error, 0.5) << "angle " << angle;
  }
}

TEST(RendererTest, ProjectedBoxCornerLandsWhereTheBoxIsDrawn) {
  const Scene scene =
      ParseScene("floor texture=checker\nbox center=0,0,100 size=200,200,200 yaw=0 target=true texture=leaves\n", ".");
  Renderer renderer(scene, RenderOptions{});
  const PinholeCamera camera = DefaultCamera();
  const Eigen::Isometry3d world_from_camera = OrbitView(20, Eigen::Vector3d(0, 0, 100));
  RenderOutput out;
  renderer.Render(camera, world_from_camera, &out);
  const Eigen::Vector3d eye = world_from_camera.translation();
  // the top corner farthest from the camera: on the silhouette, with floor around it
  Eigen::Vector3d corner(eye.x() > 0 ? -100 : 100, eye.y() > 0 ? -100 : 100, 200);
  Eigen::Vector2d pixel;
  ASSERT_TRUE(camera.Project(world_from_camera.inverse() * corner, &pixel));
  ASSERT_TRUE(camera.InImage(pixel, 5));
  int box_pixels = 0, other_pixels = 0;
  for (int dv = -2; dv <= 2; ++dv) {
    for (int du = -2; du <= 2; ++du) {
      const int u = static_cast<int>(std::lround(pixel.x())) + du, v = static_cast<int>(std::lround(pixel.y())) + dv;
      (out.object_id.at<int32_t>(v, u) == scene.target_index ? box_pixels : other_pixels)++;
    }
  }
  EXPECT_GT(box_pixels, 3);
  EXPECT_GT(other_pixels, 3);
  // Points on the top face near that corner: project, then read the surface point back from the depth buffer.
  const Eigen::Vector3d inward(-corner.x() / 100, -corner.y() / 100, 0);
  for (double step : {6.0, 15.0, 40.0}) {
    const Eigen::Vector3d point = corner + step * inward.normalized() + Eigen::Vector3d(step * 0.3, -step * 0.2, 0);
    ASSERT_TRUE(camera.Project(world_from_camera.inverse() * point, &pixel));
    Eigen::Vector3d back;
    ASSERT_TRUE(SurfacePointAt(out, camera, world_from_camera, pixel.x(), pixel.y(), &back)) << step;
    EXPECT_LT((back - point).norm(), 0.05) << "step " << step;
  }
  // On the silhouette the depth jumps: no surface point.
  ASSERT_TRUE(camera.Project(world_from_camera.inverse() * corner, &pixel));
  Eigen::Vector3d back;
  int rejected = 0;
  for (int du = -2; du <= 2; ++du) {
    if (!SurfacePointAt(out, camera, world_from_camera, pixel.x() + du, pixel.y(), &back)) ++rejected;
  }
  EXPECT_GT(rejected, 0);
  EXPECT_FALSE(SurfacePointAt(out, camera, world_from_camera, -3, 10, &back));
}

TEST(RendererTest, SameSeedGivesIdenticalImages) {
  const Scene scene = LoadScene(ScenePath("cluttered.scene"));
  const PinholeCamera camera = DefaultCamera();
  const Eigen::Isometry3d pose = OrbitView(-90, scene.TargetCenter());
  RenderOptions options;
  options.noise_seed = 5;
  Renderer a(scene, options), b(scene, options);
  RenderOutput ra, rb, rc;
  a.Render(camera, pose, &ra, 3);
  b.Render(camera, pose, &rb, 3);
  a.Render(camera, pose, &rc, 4);
  EXPECT_EQ(cv::norm(ra.rgb, rb.rgb, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(ra.depth_mm, rb.depth_mm, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(ra.rgb, rc.rgb, cv::NORM_L1), 0.0);             // other frame key: other noise
  EXPECT_EQ(cv::norm(ra.depth_mm, rc.depth_mm, cv::NORM_INF), 0.0);  // same geometry
  // The noise has the requested spread (difference of two frames: sigma * sqrt(2)).
  cv::Mat fa, fc;
  ra.rgb.convertTo(fa, CV_32F);
  rc.rgb.convertTo(fc, CV_32F);
  cv::Scalar mean, stddev;
  const cv::Mat diff = fa - fc;
  cv::meanStdDev(diff.reshape(1), mean, stddev);
  EXPECT_NEAR(stddev[0], options.noise_sigma * std::sqrt(2.0), 0.3);
  // A scene loaded again renders the same image (procedural textures are deterministic).
  const Scene scene2 = LoadScene(ScenePath("cluttered.scene"));
  Renderer c(scene2, options);
  RenderOutput rd;
  c.Render(camera, pose, &rd, 3);
  EXPECT_EQ(cv::norm(ra.rgb, rd.rgb, cv::NORM_INF), 0.0);
}

TEST(RendererTest, DefaultViewHasManyShiTomasiCorners) {
  for (const char* name : {"sphere.scene", "mesh.scene"}) {
    const Scene scene = LoadScene(ScenePath(name));
    Renderer renderer(scene);
    const PinholeCamera camera = DefaultCamera();
    RenderOutput out;
    renderer.Render(camera, OrbitView(-90, scene.TargetCenter()), &out);
    cv::Mat gray;
    cv::cvtColor(out.rgb, gray, cv::COLOR_BGR2GRAY);
    std::vector<cv::Point2f> corners;
    cv::goodFeaturesToTrack(gray, corners, 5000, 0.01, 7);
    std::printf("%s: %zu Shi-Tomasi corners\n", name, corners.size());
    EXPECT_GE(corners.size(), 1000u) << name;
    // and many of them on the target itself
    int on_target = 0;
    for (const auto& c : corners)
      if (out.object_id.at<int32_t>(cvRound(c.y), cvRound(c.x)) == scene.target_index) ++on_target;
    EXPECT_GE(on_target, 100) << name;
  }
}

TEST(RendererTest, EveryPixelIsCoveredAndTrilinearWorks) {
  const Scene scene = LoadScene(ScenePath("box.scene"));
  RenderOptions options;
  options.trilinear = true;
  options.noise_sigma = 0;
  Renderer renderer(scene, options);
  const PinholeCamera camera = DefaultCamera();
  RenderOutput out;
  renderer.Render(camera, OrbitView(45, scene.TargetCenter()), &out);
  // camera tilted down at the floor: no background and no cracks (every pixel has a surface)
  EXPECT_EQ(cv::countNonZero(out.depth_mm <= 0), 0);
  EXPECT_GT(out.triangles_drawn, 2);
}

}  // namespace
}  // namespace objscan
