// The scene file's `robot` line and the shipped rooms (scenes/rooms/room_01..10.scene, written by make_rooms.py):
// every constraint the generator enforces is checked again here with the simulator's own geometry.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <opencv2/core.hpp>

#include "common/robot_model.h"
#include "drivers/robot_sim/footprint.h"
#include "drivers/robot_sim/renderer.h"
#include "drivers/robot_sim/robot_sim.h"
#include "drivers/robot_sim/scene.h"

namespace objscan {
namespace {

constexpr double kDeg = M_PI / 180;
constexpr double kFootprintMm = 200;

std::string RoomPath(int room) {
  char name[32];
  std::snprintf(name, sizeof(name), "/rooms/room_%02d.scene", room);
  return std::string(OBJSCAN_ROBOT_SIM_SCENES_DIR) + name;
}

// The message of the error ParseScene throws ("" when it does not throw).
std::string ParseError(const std::string& text) {
  try {
    ParseScene(text, ".");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

double Wrap(double a) { return std::atan2(std::sin(a), std::cos(a)); }

TEST(SceneRobotLineTest, ParsesTheStartPoseAndWritesItBack) {
  const Scene scene = ParseScene("sphere center=0,0,100 radius=100\nrobot start=1200,-300,45 pan=10 tilt=30\n", ".");
  ASSERT_TRUE(scene.has_robot_start);
  EXPECT_EQ(scene.robot_start.x_mm, 1200);
  EXPECT_EQ(scene.robot_start.y_mm, -300);
  EXPECT_NEAR(scene.robot_start.theta_rad, 45 * kDeg, 1e-12);
  EXPECT_NEAR(scene.robot_start.pan_rad, 10 * kDeg, 1e-12);
  EXPECT_NEAR(scene.robot_start.tilt_rad, 30 * kDeg, 1e-12);
  // resolved description: written back, and it parses to the same pose
  const std::string text = scene.Describe();
  EXPECT_NE(text.find("robot start=1200,-300,45 pan=10 tilt=30\n"), std::string::npos) << text;
  const Scene again = ParseScene(text, ".");
  ASSERT_TRUE(again.has_robot_start);
  EXPECT_NEAR(again.robot_start.theta_rad, scene.robot_start.theta_rad, 1e-12);
  EXPECT_NEAR(again.robot_start.tilt_rad, scene.robot_start.tilt_rad, 1e-12);
  // defaults: pan 0, tilt 25 deg down; the yaw is wrapped to (-180, 180]
  const Scene defaults = ParseScene("robot start=0,0,270\nsphere center=0,0,100 radius=100\n", ".");
  ASSERT_TRUE(defaults.has_robot_start);
  EXPECT_EQ(defaults.robot_start.pan_rad, 0);
  EXPECT_NEAR(defaults.robot_start.tilt_rad, 25 * kDeg, 1e-12);
  EXPECT_NEAR(defaults.robot_start.theta_rad, -90 * kDeg, 1e-12);
  // without the line: nothing, and nothing written
  const Scene none = ParseScene("sphere center=0,0,100 radius=100\n", ".");
  EXPECT_FALSE(none.has_robot_start);
  EXPECT_EQ(none.Describe().find("\nrobot "), std::string::npos);
}

TEST(SceneRobotLineTest, RejectsBadValuesWithTheLineNumber) {
  const std::string object = "sphere center=0,0,100 radius=100\n";
  const std::map<std::string, std::string> cases = {
      {"robot pan=10", "start=x,y,yaw_deg is required"},
      {"robot start=1,2", "expected x,y,z"},
      {"robot start=1,2,3,", "expected x,y,z"},  // a trailing comma is a fourth, empty field
      {"robot start=nan,0,0", "not a finite number"},
      {"robot start=0,inf,0", "not a finite number"},
      {"robot start=200000,0,0", "within +-100000 mm"},
      {"robot start=0,0,400", "yaw must be in [-360, 360]"},
      {"robot start=0,0,0 pan=200", "pan must be in [-180, 180]"},
      {"robot start=0,0,0 tilt=95", "tilt must be in [-90, 90]"},
      {"robot start=0,0,0 tilt=down", "not a finite number"},
      {"robot start=0,0,0 speed=3", "unknown key 'speed' for robot"},
      {"robot start=0,0,0 start=1,1,1", "given twice"},
  };
  for (const auto& [line, expected] : cases) {
    const std::string error = ParseError(object + line + "\n");
    EXPECT_NE(error.find("scene:2: "), std::string::npos) << line << " -> " << error;
    EXPECT_NE(error.find(expected), std::string::npos) << line << " -> " << error;
  }
  const std::string twice = ParseError("robot start=0,0,0\n" + object + "robot start=100,0,0\n");
  EXPECT_NE(twice.find("scene:3: "), std::string::npos) << twice;
  EXPECT_NE(twice.find("only one robot line is allowed (the first is line 1)"), std::string::npos) << twice;
}

// ------------------------------------------------------------------------------------------------ room constraints

using Polygon = std::vector<Eigen::Vector2d>;

// Any object's floor footprint as a convex polygon (circles: circumscribed 64-gons), independent of
// FloorObstacles, which leaves drivable objects out.
Polygon FootprintPolygon(const SceneObject& o) {
  Polygon polygon;
  const OrientedBox box = ObjectBox(o);
  if (o.type == ShapeType::kSphere || o.type == ShapeType::kCylinder) {
    const double r = o.radius_mm / std::cos(M_PI / 64);
    for (int k = 0; k < 64; ++k)
      polygon.push_back(o.center_mm.head<2>() +
                        r * Eigen::Vector2d(std::cos(2 * M_PI * k / 64), std::sin(2 * M_PI * k / 64)));
  } else if (o.type == ShapeType::kBox) {
    const Eigen::Rotation2Dd yaw(box.yaw_rad);
    const double hx = box.size_mm.x() / 2, hy = box.size_mm.y() / 2;
    for (const Eigen::Vector2d& corner :
         {Eigen::Vector2d(-hx, -hy), Eigen::Vector2d(hx, -hy), Eigen::Vector2d(hx, hy), Eigen::Vector2d(-hx, hy)})
      polygon.push_back(box.center_mm.head<2>() + yaw * corner);
  } else {
    Polygon points;
    for (const Eigen::Vector3f& p : o.mesh.positions) points.push_back(p.head<2>().cast<double>());
    polygon = ConvexHull(points);
  }
  return polygon;
}

// Separating-axis test: true when the convex polygons share any point.
bool PolygonsOverlap(const Polygon& a, const Polygon& b) {
  for (const Polygon* edges : {&a, &b}) {
    for (size_t i = 0; i < edges->size(); ++i) {
      const Eigen::Vector2d d = (*edges)[(i + 1) % edges->size()] - (*edges)[i];
      const Eigen::Vector2d axis(d.y(), -d.x());
      double a_min = 1e300, a_max = -1e300, b_min = 1e300, b_max = -1e300;
      for (const auto& p : a) a_min = std::min(a_min, axis.dot(p)), a_max = std::max(a_max, axis.dot(p));
      for (const auto& p : b) b_min = std::min(b_min, axis.dot(p)), b_max = std::max(b_max, axis.dot(p));
      if (a_max < b_min || b_max < a_min) return false;
    }
  }
  return true;
}

bool IsWall(const SceneObject& o) { return o.name.rfind("wall_", 0) == 0; }

struct RoomFacts {
  Eigen::AlignedBox2d interior;  // free inside of the walls
  double wall_height_mm = 0;
};

// Checks the four walls: 100 mm thick boxes, 800-1200 mm high, closing a 5-7 m rectangle.
RoomFacts CheckWalls(const Scene& scene, const std::string& name) {
  RoomFacts facts;
  std::vector<const SceneObject*> thin_x, thin_y;  // east/west walls (100 mm along x), north/south
  for (const SceneObject& o : scene.objects) {
    if (!IsWall(o)) continue;
    EXPECT_EQ(o.type, ShapeType::kBox) << name << " " << o.name;
    EXPECT_NEAR(o.yaw_rad, 0, 1e-12) << name << " " << o.name;
    EXPECT_NE(o.texture.kind, "solid") << name << " " << o.name;
    EXPECT_GE(o.size_mm.z(), 800) << name;
    EXPECT_LE(o.size_mm.z(), 1200) << name;
    EXPECT_NEAR(o.bounds.min().z(), 0, 1e-3) << name << " " << o.name;
    facts.wall_height_mm = o.size_mm.z();
    if (std::abs(o.size_mm.x() - 100) < 1e-9) thin_x.push_back(&o);
    if (std::abs(o.size_mm.y() - 100) < 1e-9) thin_y.push_back(&o);
  }
  EXPECT_EQ(thin_x.size(), 2u) << name;
  EXPECT_EQ(thin_y.size(), 2u) << name;
  if (thin_x.size() != 2 || thin_y.size() != 2) return facts;
  if (thin_x[0]->center_mm.x() > thin_x[1]->center_mm.x()) std::swap(thin_x[0], thin_x[1]);
  if (thin_y[0]->center_mm.y() > thin_y[1]->center_mm.y()) std::swap(thin_y[0], thin_y[1]);
  const Eigen::Vector2d lo(thin_x[0]->bounds.max().x(), thin_y[0]->bounds.max().y());
  const Eigen::Vector2d hi(thin_x[1]->bounds.min().x(), thin_y[1]->bounds.min().y());
  facts.interior = Eigen::AlignedBox2d(lo, hi);
  const Eigen::Vector2d side = hi - lo;
  EXPECT_GE(side.minCoeff(), 5000) << name;
  EXPECT_LE(side.maxCoeff(), 7000) << name;
  // closed: the east/west walls span the depth, the north/south walls the width and the corners
  for (const SceneObject* w : thin_x) {
    EXPECT_LE(w->bounds.min().y(), lo.y() + 1e-3) << name;
    EXPECT_GE(w->bounds.max().y(), hi.y() - 1e-3) << name;
  }
  for (const SceneObject* w : thin_y) {
    EXPECT_LE(w->bounds.min().x(), lo.x() - 100 + 1e-3) << name;
    EXPECT_GE(w->bounds.max().x(), hi.x() + 100 - 1e-3) << name;
  }
  return facts;
}

// The roles of the room's objects (not walls, not the floor): table, pillar, rug, untextured small object.
void CheckObjectRoles(const Scene& scene, const RoomFacts& facts, const std::string& name) {
  int objects = 0, tables = 0, pillars = 0, rugs = 0, plain = 0, targets = 0;
  for (const SceneObject& o : scene.objects) {
    if (o.type == ShapeType::kFloor) {
      EXPECT_EQ(o.texture.kind, "leaves") << name;
      continue;
    }
    if (IsWall(o)) continue;
    ++objects;
    const OrientedBox box = ObjectBox(o);
    const double long_side = std::max(box.size_mm.x(), box.size_mm.y());
    const double short_side = std::min(box.size_mm.x(), box.size_mm.y());
    EXPECT_TRUE(facts.interior.contains(box.center_mm.head<2>())) << name << " " << o.name;
    EXPECT_NEAR(o.bounds.min().z(), 0, 0.6) << name << " " << o.name << " rests on the floor";
    if (o.is_target) {
      ++targets;
      EXPECT_GE(box.size_mm.minCoeff(), 80) << name;
      EXPECT_LE(box.size_mm.maxCoeff(), 300) << name;
      EXPECT_NE(o.texture.kind, "solid") << name;
    } else if (o.type == ShapeType::kBox && long_side >= 700 && long_side <= 1000 && short_side >= 500 &&
               short_side <= 700 && std::abs(box.size_mm.z() - 700) < 1e-9) {
      ++tables;
    } else if (o.type == ShapeType::kCylinder && o.radius_mm >= 200) {
      ++pillars;
      EXPECT_NEAR(o.height_mm, facts.wall_height_mm, 1e-9) << name;
    } else if (o.bounds.max().z() < kDrivableHeightMm) {
      ++rugs;
      EXPECT_NE(o.texture.kind, "solid") << name;
      EXPECT_GE(short_side, 600) << name;
      EXPECT_LE(long_side, 1200) << name;
    } else if (o.texture.kind == "solid") {
      ++plain;
      EXPECT_GE(box.size_mm.maxCoeff(), 100) << name;
      EXPECT_LE(box.size_mm.maxCoeff(), 250) << name;
    } else {
      EXPECT_GT(box.size_mm.maxCoeff(), 300) << name << " " << o.name << ": a distractor too big to be a target";
    }
  }
  EXPECT_GE(objects, 3) << name;
  EXPECT_LE(objects, 6) << name;
  EXPECT_EQ(targets, 1) << name;
  EXPECT_EQ(tables, 1) << name;
  EXPECT_EQ(pillars, 1) << name;
  EXPECT_EQ(rugs, 1) << name;
  EXPECT_EQ(plain, 1) << name;
}

void CheckStartAndRing(const Scene& scene, const RoomFacts& facts, const std::string& name) {
  const Eigen::Vector2d target = scene.TargetCenter().head<2>();
  ASSERT_TRUE(scene.has_robot_start) << name;
  const RobotStart& start = scene.robot_start;
  const Eigen::Vector2d start_xy(start.x_mm, start.y_mm);
  EXPECT_TRUE(facts.interior.contains(start_xy)) << name;
  EXPECT_GE((target - start_xy).norm(), 1500) << name;
  const Eigen::Vector2d to_target = target - start_xy;
  const double bearing = std::abs(Wrap(std::atan2(to_target.y(), to_target.x()) - start.theta_rad));
  EXPECT_GE(bearing, 70 * kDeg) << name << ": the start faces the target";
  const FootprintChecker checker(scene, kFootprintMm);
  EXPECT_GE(checker.Clearance(start_xy), 0) << name << ": the start footprint is not free";
  // Free ring: every point within 1100 mm of the target centre is >= 300 mm from any other non-drivable footprint
  // (the walls included). Exact for convex footprints: their distance from the centre is >= 1400 mm ...
  for (const FloorObstacle& f : checker.obstacles()) {
    if (f.object_id == scene.target_index) continue;
    EXPECT_GE(f.SignedDistance(target), 1100 + kFootprintMm + 100) << name << " " << f.name;
    // ... and literally, on a polar grid of the disc.
    double worst = 1e300;
    for (double r = 0; r <= 1100; r += 50)
      for (double a = 0; a < 360; a += 3)
        worst = std::min(worst, f.SignedDistance(target + r * Eigen::Vector2d(std::cos(a * kDeg), std::sin(a * kDeg))));
    EXPECT_GE(worst, kFootprintMm + 100) << name << " " << f.name;
  }
}

// Orbits of radius 500, 800 and 1000 mm around the target touch nothing.
void CheckOrbitsFit(const Scene& scene, const std::string& name) {
  for (const double radius : {500.0, 800.0, 1000.0}) {
    RobotSimOptions options;
    options.orbit_radius_mm = radius;
    options.frames = 120;
    RobotSimulator sim(scene, options);
    while (!sim.Done()) sim.Step();
    EXPECT_EQ(sim.blocked_frames(), 0) << name << " orbit radius " << radius;
  }
}

void CheckNoOverlapAndVisibility(const Scene& scene, const RoomFacts& facts, const std::string& name) {
  for (size_t i = 0; i < scene.objects.size(); ++i) {
    for (size_t j = i + 1; j < scene.objects.size(); ++j) {
      const SceneObject &a = scene.objects[i], &b = scene.objects[j];
      if (a.type == ShapeType::kFloor || b.type == ShapeType::kFloor || (IsWall(a) && IsWall(b))) continue;
      EXPECT_FALSE(PolygonsOverlap(FootprintPolygon(a), FootprintPolygon(b)))
          << name << ": " << a.name << " and " << b.name << " overlap";
    }
  }
  // The target is not hidden from everywhere: from a 250 mm grid of free base positions, the floor line to the
  // target centre crosses no other non-drivable footprint from at least half of them.
  const FootprintChecker checker(scene, kFootprintMm);
  const Eigen::Vector2d target = scene.TargetCenter().head<2>();
  int free = 0, seeing = 0;
  for (double x = facts.interior.min().x(); x <= facts.interior.max().x(); x += 250) {
    for (double y = facts.interior.min().y(); y <= facts.interior.max().y(); y += 250) {
      const Eigen::Vector2d p(x, y);
      if (checker.Clearance(p) < 0) continue;
      ++free;
      bool blocked = false;
      for (const FloorObstacle& f : checker.obstacles())
        if (f.object_id != scene.target_index && f.IntersectsSegment(p, target)) blocked = true;
      seeing += !blocked;
    }
  }
  EXPECT_GT(free, 100) << name;
  EXPECT_GE(seeing, 0.5 * free) << name << ": the target is in line of sight from " << seeing << " of " << free;
}

TEST(RoomsTest, EveryShippedRoomMeetsItsConstraints) {
  std::map<ShapeType, int> target_shapes;
  for (int room = 1; room <= 10; ++room) {
    const std::string path = RoomPath(room);
    SCOPED_TRACE(path);
    const Scene scene = LoadScene(path);
    const RoomFacts facts = CheckWalls(scene, path);
    ASSERT_FALSE(facts.interior.isEmpty()) << path;
    CheckObjectRoles(scene, facts, path);
    CheckStartAndRing(scene, facts, path);
    CheckOrbitsFit(scene, path);
    CheckNoOverlapAndVisibility(scene, facts, path);
    ++target_shapes[scene.target().type];
    if (scene.target().type == ShapeType::kMesh) {
      EXPECT_NE(scene.target().mesh_path.find("blob.ply"), std::string::npos) << path;
    }
  }
  for (const ShapeType shape : {ShapeType::kSphere, ShapeType::kBox, ShapeType::kCylinder, ShapeType::kMesh})
    EXPECT_GE(target_shapes[shape], 2) << ShapeName(shape);
}

TEST(RoomsTest, Room01StartViewShowsFloorAndWallsButNotTheTarget) {
  const Scene scene = LoadScene(RoomPath(1));
  RobotSimOptions options;
  options.mode = "command";
  options.frames = 1;
  RobotSimulator sim(scene, options);
  const SimFrame frame = sim.Step();
  // the command mode starts at the scene's robot line
  EXPECT_EQ(frame.truth.x_mm, scene.robot_start.x_mm);
  EXPECT_EQ(frame.truth.y_mm, scene.robot_start.y_mm);
  EXPECT_NEAR(frame.truth.tilt_rad, 25 * kDeg, 1e-12);
  PinholeCamera camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = camera.fy = 800;
  camera.cx = 319.5;
  camera.cy = 239.5;
  RenderOptions render_options;
  render_options.noise_sigma = 0;
  Renderer renderer(scene, render_options);
  RenderOutput out;
  renderer.Render(camera, frame.world_from_camera, &out, 0);
  std::map<std::string, int> pixels;
  int background = 0;
  for (int v = 0; v < out.object_id.rows; ++v) {
    for (int u = 0; u < out.object_id.cols; ++u) {
      const int id = out.object_id.at<int32_t>(v, u);
      if (id < 0) {
        ++background;
        continue;
      }
      const SceneObject& o = scene.objects[static_cast<size_t>(id)];
      const char* what = "other";
      if (o.is_target)
        what = "target";
      else if (o.type == ShapeType::kFloor)
        what = "floor";
      else if (IsWall(o))
        what = "wall";
      ++pixels[what];
    }
  }
  const int total = camera.width * camera.height;
  EXPECT_EQ(pixels["target"], 0);
  EXPECT_GT(pixels["floor"], 0.4 * total);
  EXPECT_GT(pixels["wall"], 0.03 * total);
  EXPECT_EQ(background, 0) << "the room is closed";
  // a textured view, not a blank one
  cv::Scalar mean, stddev;
  cv::meanStdDev(out.rgb, mean, stddev);
  EXPECT_GT(stddev[0] + stddev[1] + stddev[2], 30);
  std::printf("room_01 start view: floor %.0f %%, walls %.0f %%, other objects %.0f %%\n",
              100.0 * pixels["floor"] / total, 100.0 * pixels["wall"] / total, 100.0 * pixels["other"] / total);
}

}  // namespace
}  // namespace objscan
