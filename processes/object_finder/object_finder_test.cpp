#include "processes/object_finder/object_finder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "processes/object_finder/synthetic_room.h"

namespace objscan {
namespace {

using testing_support::SyntheticRoom;

constexpr double kDeg = M_PI / 180.0;
const Eigen::Vector3d kBoxSize(150, 120, 140);  // the target: 150 x 120 x 140 mm, yaw 20 deg, at the origin
constexpr double kBoxYaw = 20 * kDeg;
const Eigen::Vector2d kSingleViewAt(700, 150);  // a valid-looking box observed in one keyframe only
constexpr int kSingleViewUpdate = 4;            // the keyframe that sees it (camera at (1300, 0) looking at -x)

double Horizontal(const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return (a - b).head<2>().norm(); }

const ClusterReport* ClusterNear(const FinderResult& r, const Eigen::Vector3d& p, double radius) {
  const ClusterReport* best = nullptr;
  for (const auto& c : r.clusters)
    if (Horizontal(c.box.centre_mm, p) < radius && (!best || c.box.points > best->box.points)) best = &c;
  return best;
}

// The room: floor with noise, the target, a valid sphere far away, a wall segment, a table-sized box, a
// pillar, a small untextured box, phantom points and a single-view cluster. Floor frame; world_from_floor places it.
struct MainRoom {
  explicit MainRoom(const Eigen::Isometry3d& world_from_floor = Eigen::Isometry3d::Identity()) {
    room.world_from_floor = world_from_floor;
    room.AddFloor(3000, 2500, 2.0);
    box = room.AddBox("box", Eigen::Vector2d(0, 0), kBoxSize, kBoxYaw, 12);
    room.AddSphere("sphere", Eigen::Vector2d(2300, 600), 200, 12);
    room.AddWall("wall", Eigen::Vector2d(-2800, -1500), Eigen::Vector2d(-2800, 1500), 1000, 3);
    room.AddBox("table", Eigen::Vector2d(500, 2600), Eigen::Vector3d(900, 600, 700), 0, 3);
    room.AddCylinder("pillar", Eigen::Vector2d(600, -2500), 150, 1400, 3);
    room.AddBox("untextured", Eigen::Vector2d(1800, -1200), Eigen::Vector3d(120, 120, 120), 0.3, 0.6);
    single = room.AddBox("single", kSingleViewAt, Eigen::Vector3d(150, 150, 150), 0, 12);
    room.object(single).only_update = kSingleViewUpdate;
    room.AddPhantoms(40, 2500, 100, 1200);
  }
  // Keyframe k of a circle of radius 1300 mm about the target, 22.5 deg apart, looking at it.
  Eigen::Isometry3d Pose(int k) const {
    return room.OnCircle(Eigen::Vector2d(0, 0), 1300, k * 22.5 - 90, Eigen::Vector3d(0, 0, 70));
  }
  Eigen::Vector3d World(double x, double y, double z) const { return room.World(Eigen::Vector3d(x, y, z)); }

  SyntheticRoom room;
  int box = -1, single = -1;
};

void ExpectTargetBox(const FinderResult& r, const MainRoom& m) {
  const Eigen::Vector3d truth = m.World(0, 0, 0.5 * kBoxSize.z());
  EXPECT_LT((r.box.centre_mm - truth).norm(), 10.0) << r.box.centre_mm.transpose() << " vs " << truth.transpose();
  EXPECT_NEAR(r.box.size_mm.x(), kBoxSize.x(), 15.0);
  EXPECT_NEAR(r.box.size_mm.y(), kBoxSize.y(), 15.0);
  EXPECT_NEAR(r.box.size_mm.z(), kBoxSize.z(), 15.0);
  EXPECT_NEAR(r.box.yaw_rad, kBoxYaw, 3 * kDeg);
  ::testing::Test::RecordProperty("centre_error_mm", std::to_string((r.box.centre_mm - truth).norm()));
  ::testing::Test::RecordProperty("size_error_mm", std::to_string((r.box.size_mm - kBoxSize).cwiseAbs().maxCoeff()));
  ::testing::Test::RecordProperty("yaw_error_deg", std::to_string((r.box.yaw_rad - kBoxYaw) / kDeg));
}

TEST(ObjectFinderTest, ConfirmsOnlyTheTargetInARoom) {
  MainRoom m;
  ObjectFinder finder;
  const Eigen::Vector3d target = m.World(0, 0, 70);
  bool single_view_was_candidate = false;
  for (int k = 0; k < 16; ++k) {
    ASSERT_TRUE(finder.Update(m.room.Observe(m.Pose(k), 100 + k)));
    const FinderResult& r = finder.result();
    ASSERT_TRUE(r.floor_valid);
    if (k < 2) {
      EXPECT_NE(r.state, TargetState::kConfirmed) << "confirmed after " << k + 1 << " views";
    }
    if (r.state == TargetState::kConfirmed || r.state == TargetState::kLost) {
      EXPECT_LT(Horizontal(r.box.centre_mm, target), 20.0) << "update " << k << ": only the box may be confirmed";
    }
    for (const auto& c : r.other_candidates) {
      const bool sphere = Horizontal(c.box.centre_mm, m.World(2300, 600, 0)) < 60;
      const bool single = Horizontal(c.box.centre_mm, m.World(700, 150, 0)) < 60;
      EXPECT_TRUE(sphere || single) << "update " << k << ": candidate at " << c.box.centre_mm.transpose();
      if (single) {
        EXPECT_EQ(c.views, 1);
        single_view_was_candidate = true;
      }
    }
  }
  const FinderResult& r = finder.result();
  ASSERT_EQ(r.state, TargetState::kConfirmed);
  ExpectTargetBox(r, m);
  EXPECT_GE(r.confirmed_seq, 102);  // needs three spread views
  EXPECT_LE(r.confirmed_seq, 104);
  EXPECT_GE(r.views, 12);
  EXPECT_GT(r.confidence, 0.8);
  EXPECT_GT(r.roi.width, 50);  // the last camera looks at it from 1.3 m: ~90 px wide
  EXPECT_TRUE(single_view_was_candidate) << "the single-view cluster passes the rule: persistence must stop it";
  // the sphere is the other candidate, far from the robot (seen from one side 3.6 m away: its box leans that way)
  ASSERT_EQ(r.other_candidates.size(), 1u);
  EXPECT_LT(Horizontal(r.other_candidates[0].box.centre_mm, m.World(2300, 600, 0)), 60.0);
  EXPECT_GT(r.other_candidates[0].distance_mm, 2000.0);
  // too big or too high; their sparse pieces are not isolated
  for (const auto& [x, y, size_x, size_y, what] :
       {std::tuple<double, double, double, double, const char*>{-2800, 0, 100, 3000, "wall"},
        {500, 2600, 900, 600, "table"},
        {600, -2500, 300, 300, "pillar"}}) {
    int clusters = 0, points = 0;
    std::map<std::string, int> rejected_pieces;  // pieces of target size and more, by reason
    for (const auto& c : r.clusters) {
      const Eigen::Vector3d d = c.box.centre_mm - m.World(x, y, 0);
      if (std::abs(d.x()) > 0.5 * size_x + 50 || std::abs(d.y()) > 0.5 * size_y + 50) continue;
      ++clusters;
      points += c.box.points;
      EXPECT_FALSE(c.passes) << what << " piece of " << c.box.points << " points at " << c.box.centre_mm.transpose();
      EXPECT_FALSE(c.rejection.empty()) << what;
      if (c.box.points >= 15) ++rejected_pieces[c.rejection];
    }
    EXPECT_GT(points, 30) << what << " seen in " << clusters << " clusters";
    std::string reasons;
    for (const auto& [reason, n] : rejected_pieces) reasons += reason + " " + std::to_string(n) + ", ";
    RecordProperty(what, reasons);
    EXPECT_GT(rejected_pieces["too high"] + rejected_pieces["too large"], 0) << what << ": " << reasons;
  }
  const ClusterReport* untextured = ClusterNear(r, m.World(1800, -1200, 0), 200);
  if (untextured) {
    EXPECT_FALSE(untextured->passes);
  }
  EXPECT_GT(r.floor_points, 2000);
}

TEST(ObjectFinderTest, TiltedOffsetFloor) {
  Eigen::Isometry3d world_from_floor = Eigen::Isometry3d::Identity();
  world_from_floor.linear() = Eigen::AngleAxisd(4 * kDeg, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
  world_from_floor.translation() = Eigen::Vector3d(200, -100, 150);
  MainRoom m(world_from_floor);
  ObjectFinder finder;
  for (int k = 0; k < 16; ++k) ASSERT_TRUE(finder.Update(m.room.Observe(m.Pose(k), k)));
  const FinderResult& r = finder.result();
  ASSERT_TRUE(r.floor_valid);
  const Eigen::Vector3d normal = world_from_floor.linear() * Eigen::Vector3d::UnitZ();
  EXPECT_LT(std::acos(std::min(1.0, r.floor.normal.dot(normal))), 0.3 * kDeg);
  EXPECT_NEAR(r.floor.Height(world_from_floor.translation()), 0.0, 2.0);
  ASSERT_EQ(r.state, TargetState::kConfirmed);
  ExpectTargetBox(r, m);
}

// Two valid objects, both in every view: a box A at the origin and a 200 mm sphere B at (700, 0).
struct TwoObjects {
  TwoObjects() {
    room.AddFloor(2500, 2000, 2.0);
    room.AddBox("A", Eigen::Vector2d(0, 0), kBoxSize, 0, 12);
    room.AddSphere("B", Eigen::Vector2d(700, 0), 200, 12);
  }
  FinderInput View(double angle_deg, int64_t seq) {
    return room.Observe(room.OnCircle(Eigen::Vector2d(350, 0), 1500, angle_deg, Eigen::Vector3d(350, 0, 80)), seq);
  }
  SyntheticRoom room;
};

TEST(ObjectFinderTest, NearestCandidateWinsAndKeepsTheTarget) {
  TwoObjects s;
  ObjectFinder finder;
  int64_t seq = 0;
  for (double a = -40; a <= 35; a += 15) ASSERT_TRUE(finder.Update(s.View(a, seq++)));  // the robot is nearer B
  const FinderResult& r = finder.result();
  ASSERT_EQ(r.state, TargetState::kConfirmed);
  // the sphere is seen from one side only: its box centre leans towards the cameras
  EXPECT_LT(Horizontal(r.box.centre_mm, Eigen::Vector3d(700, 0, 0)), 40.0);
  ASSERT_EQ(r.other_candidates.size(), 1u);
  EXPECT_LT(Horizontal(r.other_candidates[0].box.centre_mm, Eigen::Vector3d(0, 0, 0)), 15.0);
  EXPECT_GE(r.other_candidates[0].views, 3);  // A would have been confirmable too
  const int target = r.track_id;
  // now the robot is nearer A: a confirmed target is not taken over
  for (double a = 145; a <= 215; a += 15) ASSERT_TRUE(finder.Update(s.View(a, seq++)));
  EXPECT_EQ(r.state, TargetState::kConfirmed);
  EXPECT_EQ(r.track_id, target);
  ASSERT_EQ(r.other_candidates.size(), 1u);
  const Eigen::Vector3d robot(350 + 1500 * std::cos(215 * kDeg), 1500 * std::sin(215 * kDeg), 0);
  EXPECT_LT(r.other_candidates[0].distance_mm, Horizontal(r.box.centre_mm, robot) - 400);
}

// room_10: an untextured sphere nearer the robot than the textured target. Its landmarks are the corners the
// floor's texture makes with its outline: dense enough for the density rule, but they slide with the view, so their
// reprojection error is several times the map's (there 0.38-0.46 px against 0.058 px). A cluster of them is
// "outline only" (median above 3x the map's); points above 5x are left out before clustering. Either way the
// textured object behind it is the target; the same object as consistent as the map is a valid object.
TEST(ObjectFinderTest, AnOutlineOnlyObjectIsNoTarget) {
  const Eigen::Vector3d outline_at(350, -500, 0);
  struct Case {
    double map_error_px, outline_error_px;
    const char* expect;  // "outline only", "left out", "passes"
  };
  for (const Case& k : {Case{0.5, 1.8, "outline only"}, Case{0.1, 1.8, "left out"}, Case{0.5, 0.5, "passes"}}) {
    SCOPED_TRACE(k.expect);
    TwoObjects s;
    for (int object = 0; object < 3; ++object) s.room.object(object).error_px = k.map_error_px;  // floor, A, B
    const int outline = s.room.AddSphere("outline", outline_at.head<2>(), 150, 12);
    s.room.object(outline).error_px = k.outline_error_px;
    ObjectFinder finder;
    int64_t seq = 0;
    for (double a = -40; a <= 35; a += 15) ASSERT_TRUE(finder.Update(s.View(a, seq++)));
    const FinderResult& r = finder.result();
    EXPECT_NEAR(r.map_error_px, k.map_error_px, 1e-6);
    ASSERT_EQ(r.state, TargetState::kConfirmed);
    const ClusterReport* c = ClusterNear(r, s.room.World(outline_at), 150);
    if (std::string(k.expect) == "passes") {
      EXPECT_EQ(r.points_inconsistent, 0);
      ASSERT_NE(c, nullptr);
      EXPECT_TRUE(c->passes) << c->rejection;
      continue;
    }
    if (std::string(k.expect) == "outline only") {
      EXPECT_EQ(r.points_inconsistent, 0);
      ASSERT_NE(c, nullptr);
      EXPECT_EQ(c->rejection, "outline only");
      EXPECT_NEAR(c->box.median_error_px, 1.8, 1e-6);
    } else {
      EXPECT_GT(r.points_inconsistent, 30);
      EXPECT_EQ(c, nullptr);
    }
    EXPECT_GT(Horizontal(r.box.centre_mm, s.room.World(outline_at)), 300.0);
    for (const auto& o : r.other_candidates) EXPECT_GT(Horizontal(o.box.centre_mm, s.room.World(outline_at)), 300.0);
  }
}

TEST(ObjectFinderTest, NearestCandidateFromTheOtherSide) {
  TwoObjects s;
  ObjectFinder finder;
  int64_t seq = 0;
  for (double a = 145; a <= 220; a += 15) ASSERT_TRUE(finder.Update(s.View(a, seq++)));
  const FinderResult& r = finder.result();
  ASSERT_EQ(r.state, TargetState::kConfirmed);
  EXPECT_LT(Horizontal(r.box.centre_mm, Eigen::Vector3d(0, 0, 0)), 15.0);
  ASSERT_EQ(r.other_candidates.size(), 1u);
  EXPECT_LT(Horizontal(r.other_candidates[0].box.centre_mm, Eigen::Vector3d(700, 0, 0)), 40.0);
}

// A large target seen first from one side: the box of the part seen so far moves as more of it comes into view, and
// the views must still confirm it soon (room_01, 7 Dec: a 268 mm sphere stayed a candidate for 22 s, its box grew
// from 110 x 240 to 163 x 251 mm, its centre moved 49 mm; the run's log was not kept, hence not_confirmed_why).
// Views 20 deg apart on a 1 m circle, starting on one side; until confirmed, the candidate says what it lacks.
TEST(ObjectFinderTest, ALargeTargetSeenFromOneSideFirstIsConfirmedWithinAQuarterTurn) {
  SyntheticRoom room;
  room.AddFloor(2500, 2000, 2.0);
  room.AddSphere("sphere", Eigen::Vector2d(0, 0), 268, 12);
  ObjectFinder finder;
  int confirmed_at = -1;
  for (int k = 0; k < 10 && confirmed_at < 0; ++k) {
    ASSERT_TRUE(finder.Update(
        room.Observe(room.OnCircle(Eigen::Vector2d(0, 0), 1000, 20.0 * k, Eigen::Vector3d(0, 0, 134)), k)));
    const FinderResult& r = finder.result();
    std::printf("view %d (%3.0f deg): %s, %d views, box centre (%.0f, %.0f) mm, %.0f x %.0f x %.0f mm\n", k, 20.0 * k,
                TargetStateName(r.state), r.views, r.box.centre_mm.x(), r.box.centre_mm.y(), r.box.size_mm.x(),
                r.box.size_mm.y(), r.box.size_mm.z());
    if (r.state == TargetState::kConfirmed) confirmed_at = k;
    if (r.state == TargetState::kCandidate) {
      EXPECT_NE(r.not_confirmed_why.find(std::to_string(r.views) + " of 3 views"), std::string::npos)
          << r.not_confirmed_why;
    } else {
      EXPECT_EQ(r.not_confirmed_why, "");
    }
  }
  EXPECT_GE(confirmed_at, 2);  // three distinct views at least
  EXPECT_LE(confirmed_at, 4);  // within 80 deg of the first view
}

TEST(ObjectFinderTest, OneViewpointNeverConfirms) {
  SyntheticRoom room;
  room.AddFloor(2500, 2000, 2.0);
  room.AddBox("box", Eigen::Vector2d(0, 0), kBoxSize, 0, 12);
  ObjectFinder finder;
  const Eigen::Isometry3d pose = room.OnCircle(Eigen::Vector2d(0, 0), 1000, 30, Eigen::Vector3d(0, 0, 70));
  for (int k = 0; k < 12; ++k) {
    // the robot stands still (the map is re-observed every keyframe) and pans a little
    const Eigen::Isometry3d panned = pose * Eigen::AngleAxisd((k % 3 - 1) * 2 * kDeg, Eigen::Vector3d::UnitY());
    ASSERT_TRUE(finder.Update(room.Observe(panned, k)));
    EXPECT_EQ(finder.result().state, TargetState::kCandidate) << k;
    EXPECT_EQ(finder.result().views, 1) << k;
    EXPECT_NE(finder.result().not_confirmed_why.find("1 of 3 views"), std::string::npos)
        << finder.result().not_confirmed_why;
  }
}

// Far views make objects look larger (room_05: a 258 x 218 mm box measured 359 x 250 mm from 2-3 m): a cluster that
// fails only the size limits by a little and was only seen from afar is a candidate (the robot goes to look, with no
// views it cannot confirm); seen from near, the rule decides. Here the box (150 x 120 x 140 mm) is made a little too
// large for the rule (max 120 mm, 138 with the tolerance).
TEST(ObjectFinderTest, AClusterALittleTooLargeSeenOnlyFromAfarIsACandidateToLookAtCloser) {
  SyntheticRoom room;
  room.AddFloor(5000, 5000, 2.0);
  room.AddBox("box", Eigen::Vector2d(0, 0), kBoxSize, kBoxYaw, 12);
  ObjectFinderOptions options;
  options.target_max_size_mm = 120;
  auto far_then_near = [&](ObjectFinder* finder, std::vector<TargetState>* states) {
    for (int k = 0; k < 6; ++k) {
      ASSERT_TRUE(finder->Update(
          room.Observe(room.OnCircle(Eigen::Vector2d(0, 0), 2000, k * 20 - 60, Eigen::Vector3d(0, 0, 70)), k)));
      states->push_back(finder->result().state);
    }
    for (int k = 6; k < 12; ++k) {
      ASSERT_TRUE(finder->Update(
          room.Observe(room.OnCircle(Eigen::Vector2d(0, 0), 800, k * 20 - 60, Eigen::Vector3d(0, 0, 70)), k)));
      states->push_back(finder->result().state);
    }
  };
  ObjectFinder finder(options);
  std::vector<TargetState> states;
  far_then_near(&finder, &states);
  ASSERT_EQ(states.size(), 12u);
  EXPECT_EQ(states[5], TargetState::kCandidate);  // from 2 m: look closer
  for (int k = 8; k < 12; ++k) EXPECT_EQ(states[k], TargetState::kSearching) << k;  // from 0.8 m: too large
  for (const TargetState s : states) EXPECT_NE(s, TargetState::kConfirmed);  // never without passing views

  options.look_closer_margin = 0;  // off: never a candidate
  ObjectFinder strict(options);
  states.clear();
  far_then_near(&strict, &states);
  for (const TargetState s : states) EXPECT_EQ(s, TargetState::kSearching);

  options.look_closer_margin = 0.25;
  options.target_max_size_mm = 90;  // 150 mm against 103.5 (x 1.25 = 129): too large by more than the margin
  ObjectFinder far_too_large(options);
  states.clear();
  far_then_near(&far_too_large, &states);
  for (const TargetState s : states) EXPECT_EQ(s, TargetState::kSearching);
}

// A target seen sparsely (landmarks ~70 mm apart: the robot drove past it looking ahead) falls apart at the 50 mm
// linkage into pieces that reject each other; linked again at twice the distance, the pieces are one target. A wall
// as sparse falls apart too, and its pieces merge into something too large, never a target.
TEST(ObjectFinderTest, SparseTargetInPiecesIsStillFound) {
  SyntheticRoom room;
  room.AddFloor(3000, 2500, 2.0);
  room.AddSphere("sphere", Eigen::Vector2d(0, 0), 260, 2.0);
  room.AddWall("wall", Eigen::Vector2d(-1500, -1000), Eigen::Vector2d(-1500, 1000), 800, 2.0);
  ObjectFinder finder;
  for (int k = 0; k < 12; ++k)
    ASSERT_TRUE(finder.Update(
        room.Observe(room.OnCircle(Eigen::Vector2d(0, 0), 1300, k * 30 - 90, Eigen::Vector3d(0, 0, 130)), k)));
  const FinderResult& r = finder.result();
  ASSERT_EQ(r.state, TargetState::kConfirmed);
  EXPECT_LT(Horizontal(r.box.centre_mm, Eigen::Vector3d(0, 0, 0)), 30.0);
  EXPECT_NEAR(r.box.size_mm.z(), 260, 40);
  EXPECT_TRUE(r.other_candidates.empty());
  for (const auto& c : r.clusters)
    if (std::abs(c.box.centre_mm.x() + 1500) < 100) {
      EXPECT_FALSE(c.passes) << "wall piece at " << c.box.centre_mm.transpose();
    }
}

// Low clutter around the target's base (heights up to the floor contact band) is floor, not a neighbour: the target
// stays isolated (room_01: a confirmed sphere was dropped during the orbit for the noisy landmarks where it meets the
// floor, 20-40 mm high).
TEST(ObjectFinderTest, LowClutterAroundTheBaseIsNoNeighbour) {
  SyntheticRoom room;
  room.AddFloor(3000, 2500, 2.0);
  room.AddBox("box", Eigen::Vector2d(0, 0), kBoxSize, kBoxYaw, 12);
  room.AddClutter(Eigen::Vector2d(0, 0), 165, 205, 60, 12, 30);
  ObjectFinder finder;
  for (int k = 0; k < 8; ++k)
    ASSERT_TRUE(finder.Update(
        room.Observe(room.OnCircle(Eigen::Vector2d(0, 0), 1300, k * 30 - 90, Eigen::Vector3d(0, 0, 70)), k)));
  EXPECT_EQ(finder.result().state, TargetState::kConfirmed);
  EXPECT_LT(Horizontal(finder.result().box.centre_mm, Eigen::Vector3d(0, 0, 0)), 15.0);
}

// A large, densely mapped target seen again after the camera looked away: its old landmarks' tracks ended, so only
// a tenth of the members in view (a few percent of all) are seen again, but tens of them: it is observed, not missed (room_01: 1 200 members,
// 30-40 new per keyframe during the orbit, "not seen where it should be" against the 10 % = 120 needed).
TEST(ObjectFinderTest, LargeTargetSeenAgainByFewOfItsLandmarksIsNotLost) {
  SyntheticRoom room;
  room.AddFloor(3000, 2500, 2.0);
  room.AddBox("box", Eigen::Vector2d(0, 0), kBoxSize, kBoxYaw, 60);
  ObjectFinder finder;
  for (int k = 0; k < 6; ++k)
    ASSERT_TRUE(finder.Update(
        room.Observe(room.OnCircle(Eigen::Vector2d(0, 0), 1300, k * 60 - 90, Eigen::Vector3d(0, 0, 70)), k)));
  ASSERT_EQ(finder.result().state, TargetState::kConfirmed);
  ASSERT_GT(finder.result().points, 300);
  room.refresh_fraction = 0.1;  // ~25 of the ~250 members in view
  for (int k = 6; k < 16; ++k) {
    ASSERT_TRUE(finder.Update(
        room.Observe(room.OnCircle(Eigen::Vector2d(0, 0), 1300, k * 30 - 90, Eigen::Vector3d(0, 0, 70)), k)));
    EXPECT_EQ(finder.result().state, TargetState::kConfirmed) << "update " << k;
  }
}

TEST(ObjectFinderTest, PhantomsAndSingleViewClustersNeverConfirmed) {
  SyntheticRoom room;
  room.AddFloor(3000, 2500, 2.0);
  const int single = room.AddBox("single", kSingleViewAt, Eigen::Vector3d(150, 150, 150), 0, 12);
  room.object(single).only_update = kSingleViewUpdate;
  room.AddPhantoms(150, 2500, 30, 1200, 150);
  ObjectFinder finder;
  for (int k = 0; k < 16; ++k) {
    ASSERT_TRUE(finder.Update(
        room.Observe(room.OnCircle(Eigen::Vector2d(0, 0), 1300, k * 22.5 - 90, Eigen::Vector3d(0, 0, 70)), k)));
    const FinderResult& r = finder.result();
    EXPECT_NE(r.state, TargetState::kConfirmed) << k;
    EXPECT_NE(r.state, TargetState::kLost) << k;
    for (const auto& c : r.clusters) EXPECT_GE(c.box.points, 3);
    if (k < kSingleViewUpdate) {
      EXPECT_EQ(r.state, TargetState::kSearching) << k << ": phantoms are no candidates";
    }
    if (k == kSingleViewUpdate) {
      EXPECT_EQ(r.state, TargetState::kCandidate) << "the single-view cluster passes the rule";
      EXPECT_LT(Horizontal(r.box.centre_mm, Eigen::Vector3d(700, 150, 0)), 20.0);
    }
  }
  // never seen again where it should be: no longer a candidate
  EXPECT_EQ(finder.result().state, TargetState::kSearching);
}

// The target, then: the camera turns away (still confirmed), looks at it while it is hidden (lost after 5
// keyframes), sees it again (confirmed, same track).
TEST(ObjectFinderTest, LostWhenNotSeenWhereExpectedThenFoundAgain) {
  SyntheticRoom room;
  room.AddFloor(2500, 2000, 2.0);
  const int box = room.AddBox("box", Eigen::Vector2d(0, 0), kBoxSize, kBoxYaw, 12);
  ObjectFinder finder;
  const FinderResult& r = finder.result();
  auto pose = [&](int k, bool away) {
    const double a = (k * 30 - 90) * kDeg;
    const Eigen::Vector3d eye(1300 * std::cos(a), 1300 * std::sin(a), 400);
    return room.LookAt(eye, away ? Eigen::Vector3d(2 * eye.x(), 2 * eye.y(), 70) : Eigen::Vector3d(0, 0, 70));
  };
  int64_t seq = 0;
  for (int k = 0; k < 4; ++k) ASSERT_TRUE(finder.Update(room.Observe(pose(k, false), seq++)));
  ASSERT_EQ(r.state, TargetState::kConfirmed);
  const int track = r.track_id;
  const Eigen::Vector3d centre = r.box.centre_mm;
  for (int k = 4; k < 10; ++k) {
    ASSERT_TRUE(finder.Update(room.Observe(pose(k, true), seq++)));
    EXPECT_EQ(r.state, TargetState::kConfirmed) << "out of view is not lost";
    EXPECT_EQ(r.roi.width, 0);
  }
  room.object(box).hidden = true;
  for (int k = 10; k < 16; ++k) {
    ASSERT_TRUE(finder.Update(room.Observe(pose(k, false), seq++)));
    EXPECT_EQ(r.state, k < 14 ? TargetState::kConfirmed : TargetState::kLost) << k;
    EXPECT_GT(r.roi.width, 0) << "the region says where it should be";
  }
  EXPECT_LT(r.confidence, 0.5);
  room.object(box).hidden = false;
  ASSERT_TRUE(finder.Update(room.Observe(pose(16, false), seq++)));
  EXPECT_EQ(r.state, TargetState::kConfirmed);
  EXPECT_EQ(r.track_id, track);
  EXPECT_LT((r.box.centre_mm - centre).norm(), 10.0);
}

// The map drops the target's landmarks and its cluster comes back off its track, nearer to another track's centre
// (room_03: the target's own cluster went, the whole object was a second track's cluster 78 mm away, and the target
// stayed LOST to the end): the confirmed target takes its nearest cluster first and is not lost. (Default options
// keep separate clusters too far apart for this; a wider track_match_distance_mm makes room for it.)
TEST(ObjectFinderTest, TheConfirmedTargetKeepsItsClusterWhenAnotherTrackIsNearer) {
  SyntheticRoom room;
  room.AddFloor(2500, 2000, 2.0);
  room.AddBox("box", Eigen::Vector2d(0, 0), kBoxSize, 0, 12);
  const int other = room.AddBox("other", Eigen::Vector2d(300, 0), kBoxSize, 0, 12);
  room.object(other).hidden = true;
  SyntheticRoom moved;  // the same floor, the box 170 mm further, nothing else: new landmarks
  moved.AddFloor(2500, 2000, 2.0);
  moved.AddBox("box", Eigen::Vector2d(170, 0), kBoxSize, 0, 12);
  ObjectFinderOptions options;
  options.track_match_distance_mm = 250;
  ObjectFinder finder(options);
  const FinderResult& r = finder.result();
  auto pose = [&](int k) {
    const double a = (k * 25 - 90) * kDeg;
    return room.LookAt(Eigen::Vector3d(1300 * std::cos(a), 1300 * std::sin(a), 400), Eigen::Vector3d(0, 0, 70));
  };
  int64_t seq = 0;
  for (int k = 0; k < 4; ++k) ASSERT_TRUE(finder.Update(room.Observe(pose(k), seq++)));
  ASSERT_EQ(r.state, TargetState::kConfirmed);
  const int track = r.track_id;
  room.object(other).hidden = false;  // a second track, 300 mm from the target's
  for (int k = 4; k < 6; ++k) ASSERT_TRUE(finder.Update(room.Observe(pose(k), seq++)));
  ASSERT_EQ(r.state, TargetState::kConfirmed);
  ASSERT_EQ(r.clusters.size(), 2u);
  for (int k = 6; k < 14; ++k) {  // one cluster, 170 mm from the target's track and 130 mm from the other's
    FinderInput in = moved.Observe(pose(k), seq++);
    for (auto& l : in.landmarks) l.id += 1000000;
    ASSERT_TRUE(finder.Update(in));
    EXPECT_EQ(r.state, TargetState::kConfirmed) << k;
    EXPECT_EQ(r.track_id, track) << k;
  }
  EXPECT_LT(Horizontal(r.box.centre_mm, Eigen::Vector3d(170, 0, 0)), 15.0);
}

// An object between the camera and the target (room_04: the robot bypassing an obstacle on its circle) hides it:
// not seeing it there is no miss, the target stays CONFIRMED; the same views without the screen make it LOST.
TEST(ObjectFinderTest, ATargetHiddenBehindAnotherObjectIsNotLost) {
  for (const bool with_screen : {true, false}) {
    SyntheticRoom room;
    room.AddFloor(2500, 2000, 2.0);
    const int box = room.AddBox("box", Eigen::Vector2d(0, 0), kBoxSize, kBoxYaw, 12);
    const int screen = room.AddBox("screen", Eigen::Vector2d(650, 0), Eigen::Vector3d(100, 600, 500), 0, 12);
    room.object(screen).hidden = true;
    ObjectFinder finder;
    const FinderResult& r = finder.result();
    auto pose = [&](double deg) {
      const double a = deg * kDeg;
      return room.LookAt(Eigen::Vector3d(1300 * std::cos(a), 1300 * std::sin(a), 400), Eigen::Vector3d(0, 0, 70));
    };
    int64_t seq = 0;
    for (double deg : {-110.0, -80.0, -50.0, -20.0}) ASSERT_TRUE(finder.Update(room.Observe(pose(deg), seq++)));
    ASSERT_EQ(r.state, TargetState::kConfirmed);
    room.object(screen).hidden = !with_screen;
    room.object(box).hidden = true;  // behind the screen (or, without it, gone)
    for (int k = 0; k < 8; ++k) {
      ASSERT_TRUE(finder.Update(room.Observe(pose(-4 + k), seq++)));
      if (with_screen) EXPECT_EQ(r.state, TargetState::kConfirmed) << k;
    }
    if (!with_screen) EXPECT_EQ(r.state, TargetState::kLost);
  }
}

TEST(ObjectFinderTest, ConfirmedTargetDroppedWhenManyViewsRejectIt) {
  SyntheticRoom room;
  room.AddFloor(2500, 2000, 2.0);
  room.AddBox("box", Eigen::Vector2d(0, 0), kBoxSize, 0, 12);
  const int pole = room.AddCylinder("pole", Eigen::Vector2d(0, 95), 20, 600, 12);  // 15 mm from the box's side
  room.object(pole).hidden = true;
  ObjectFinder finder;
  const FinderResult& r = finder.result();
  int64_t seq = 0;
  auto pose = [&](int k) { return room.OnCircle(Eigen::Vector2d(0, 0), 1300, k * 25 - 90, Eigen::Vector3d(0, 0, 70)); };
  for (int k = 0; k < 4; ++k) ASSERT_TRUE(finder.Update(room.Observe(pose(k), seq++)));
  ASSERT_EQ(r.state, TargetState::kConfirmed);
  room.object(pole).hidden = false;  // what looked like the target is part of something tall
  for (int k = 4; k < 10; ++k) {
    ASSERT_TRUE(finder.Update(room.Observe(pose(k), seq++)));
    const ClusterReport* c = ClusterNear(r, Eigen::Vector3d(0, 0, 0), 100);
    ASSERT_NE(c, nullptr);
    EXPECT_EQ(c->rejection, "too high");
    EXPECT_EQ(r.state, k < 8 ? TargetState::kConfirmed : TargetState::kSearching) << k;
    // The update that drops it says why (logged by the node); the others say nothing.
    if (k == 8)
      EXPECT_EQ(r.drop_reason.rfind("too high in 5 views in a row (box ", 0), 0u) << r.drop_reason;
    else
      EXPECT_TRUE(r.drop_reason.empty()) << k << ": " << r.drop_reason;
  }
  EXPECT_EQ(r.confirmed_seq, -1);
}

TEST(ObjectFinderTest, NonFiniteLandmarksAreDroppedAndCounted) {
  MainRoom clean_room, dirty_room;
  ObjectFinder clean, dirty;
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 8; ++k) {
    ASSERT_TRUE(clean.Update(clean_room.room.Observe(clean_room.Pose(k), k)));
    FinderInput in = dirty_room.room.Observe(dirty_room.Pose(k), k);
    for (int i = 0; i < 20; ++i) {
      MapLandmark bad;
      bad.id = 900000 + i;
      bad.num_observations = 10;
      bad.position_mm = Eigen::Vector3d(100, i % 2 ? nan : inf, 50);
      if (i >= 15) {
        bad.position_mm = Eigen::Vector3d(100, 0, 50);
        bad.reprojection_error_px = i % 2 ? nan : -1;
      }
      if (i == 19) bad.num_observations = -3;
      in.landmarks.insert(in.landmarks.begin() + i * 7, bad);
    }
    ASSERT_TRUE(dirty.Update(in));
    EXPECT_EQ(dirty.result().rejected_landmarks, 20);
    EXPECT_EQ(clean.result().rejected_landmarks, 0);
    EXPECT_EQ(dirty.result().state, clean.result().state);
    EXPECT_EQ(dirty.result().box.centre_mm, clean.result().box.centre_mm);
    EXPECT_EQ(dirty.result().clusters.size(), clean.result().clusters.size());
  }
  EXPECT_EQ(dirty.result().state, TargetState::kConfirmed);
}

TEST(ObjectFinderTest, EmptyAndInvalidInputsAreSafe) {
  ObjectFinder finder;
  FinderInput empty;
  std::string error;
  EXPECT_FALSE(finder.Update(empty, &error));  // no intrinsics
  EXPECT_EQ(error, "invalid camera intrinsics");
  SyntheticRoom room;
  empty.camera = room.camera();
  ASSERT_TRUE(finder.Update(empty, &error));
  EXPECT_EQ(finder.result().state, TargetState::kSearching);
  EXPECT_FALSE(finder.result().floor_valid);
  EXPECT_TRUE(finder.result().clusters.empty());
  FinderInput bad_pose = empty;
  bad_pose.world_from_camera.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(finder.Update(bad_pose, &error));
  bad_pose.world_from_camera = Eigen::Isometry3d::Identity();
  bad_pose.world_from_camera.linear() *= 2.0;  // not a rotation
  EXPECT_FALSE(finder.Update(bad_pose, &error));
  EXPECT_EQ(finder.updates(), 1);

  // a confirmed target survives an empty map (the floor and the target are kept)
  MainRoom m;
  for (int k = 0; k < 5; ++k) ASSERT_TRUE(finder.Update(m.room.Observe(m.Pose(k), k)));
  ASSERT_EQ(finder.result().state, TargetState::kConfirmed);
  const Eigen::Vector3d centre = finder.result().box.centre_mm;
  empty.world_from_camera = m.Pose(5);
  ASSERT_TRUE(finder.Update(empty));
  EXPECT_EQ(finder.result().state, TargetState::kConfirmed);
  EXPECT_TRUE(finder.result().floor_valid);
  EXPECT_EQ(finder.result().box.centre_mm, centre);
}

TEST(ObjectFinderTest, Deterministic) {
  MainRoom a, b;
  ObjectFinder fa, fb;
  for (int k = 0; k < 10; ++k) {
    ASSERT_TRUE(fa.Update(a.room.Observe(a.Pose(k), k)));
    ASSERT_TRUE(fb.Update(b.room.Observe(b.Pose(k), k)));
    ASSERT_EQ(fa.result().clusters.size(), fb.result().clusters.size());
    for (size_t i = 0; i < fa.result().clusters.size(); ++i) {
      EXPECT_EQ(fa.result().clusters[i].box.centre_mm, fb.result().clusters[i].box.centre_mm);
      EXPECT_EQ(fa.result().clusters[i].track_id, fb.result().clusters[i].track_id);
    }
    EXPECT_EQ(fa.result().floor.normal, fb.result().floor.normal);
    EXPECT_EQ(fa.result().box.centre_mm, fb.result().box.centre_mm);
  }
}

TEST(ObjectFinderTest, ImageRegionOfABox) {
  FinderCamera camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = camera.fy = 800;
  camera.cx = 319.5;
  camera.cy = 239.5;
  // camera at the origin looking along world +x (optical z = world x, optical x = -world y, optical y = -world z)
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  world_from_camera.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  TargetBox box{Eigen::Vector3d(1000, 0, 0), Eigen::Vector3d(100, 200, 100), 0};
  ImageRegion roi = ProjectBox(box, world_from_camera, camera);
  // nearest face at x = 950: +-100 mm -> +-84.2 px about the centre
  EXPECT_EQ(roi.u, 235);
  EXPECT_EQ(roi.width, 170);
  EXPECT_EQ(roi.v, 197);
  EXPECT_EQ(roi.height, 86);
  box.centre_mm.x() = -1000;  // behind
  roi = ProjectBox(box, world_from_camera, camera);
  EXPECT_EQ(roi.width, 0);
  EXPECT_EQ(roi.height, 0);
  box.centre_mm = Eigen::Vector3d(1000, 2000, 0);  // off to the left, outside the image
  EXPECT_EQ(ProjectBox(box, world_from_camera, camera).width, 0);
  box.centre_mm = Eigen::Vector3d(1000, 500, 0);  // partly outside on the left: clamped
  roi = ProjectBox(box, world_from_camera, camera);
  EXPECT_EQ(roi.u, 0);
  EXPECT_GT(roi.width, 0);
  box.centre_mm = Eigen::Vector3d(20, 0, 0);  // around the camera: the corners in front fill the image
  roi = ProjectBox(box, world_from_camera, camera);
  EXPECT_EQ(roi.width, 640);
  EXPECT_EQ(roi.height, 480);
}

// A dense model's voxels (2 mm) on the five visible faces of a 150 x 120 x 140 mm box, yaw 20 deg, standing on a
// floor tilted by 1 deg; a band of floor voxels around it and a stray group of 60 voxels 300 mm away: the box comes
// back within a voxel; a landmarks' box elsewhere, too few voxels or no voxel size: false, box untouched.
TEST(ObjectFinderTest, BoxFromTheDenseModel) {
  constexpr double kVoxel = 2.0;
  FloorPlane floor;
  floor.normal = Eigen::Vector3d(std::sin(1 * kDeg), 0, std::cos(1 * kDeg));
  floor.offset_mm = 12;
  const Eigen::Isometry3d world_from_floor = floor.FloorFromWorld().inverse();
  const Eigen::Vector2d centre_xy(400, -300);
  const Eigen::Rotation2Dd yaw(kBoxYaw);
  std::vector<Eigen::Vector3d> voxels;
  const Eigen::Vector3d half = kBoxSize / 2;
  const auto add = [&](double x, double y, double z) {  // box frame, z from the floor
    const Eigen::Vector2d xy = centre_xy + yaw * Eigen::Vector2d(x, y);
    voxels.push_back(world_from_floor * Eigen::Vector3d(xy.x(), xy.y(), z));
  };
  for (double x = -half.x(); x <= half.x(); x += kVoxel)
    for (double y = -half.y(); y <= half.y(); y += kVoxel)
      for (double z = 0; z <= kBoxSize.z(); z += kVoxel) {
        const bool side = std::abs(x) > half.x() - kVoxel / 2 || std::abs(y) > half.y() - kVoxel / 2;
        if (side || z > kBoxSize.z() - kVoxel / 2) add(x, y, z);
      }
  for (double x = -half.x() - 20; x <= half.x() + 20; x += kVoxel)  // floor band: at most one voxel up
    for (double y = -half.y() - 20; y <= half.y() + 20; y += kVoxel) add(x, y, 0.5 * kVoxel * ((int(x + y) / 2) % 2));
  for (int i = 0; i < 60; ++i) add(300 + 2 * (i % 6), 2 * (i / 6), 20);  // a stray group
  const size_t on_box = voxels.size();
  for (int i = 0; i < 50; ++i)  // carving's fuzz over the flat top: sparse voxels up to 14 mm above it
    add(-60 + 2.4 * i, 0.8 * i - 20, kBoxSize.z() + 2 + (i % 7) * 2);
  TargetBox near;  // the landmarks' box: 40 mm off, a little too large
  near.centre_mm = world_from_floor * Eigen::Vector3d(centre_xy.x() + 30, centre_xy.y() - 27, 75);
  near.size_mm = Eigen::Vector3d(170, 130, 150);
  near.yaw_rad = kBoxYaw;
  TargetBox box;
  int used = 0;
  std::string why;
  ASSERT_TRUE(BoxFromModel(voxels, kVoxel, floor, near, &box, &used, &why)) << why;
  const Eigen::Vector3d true_centre = world_from_floor * Eigen::Vector3d(centre_xy.x(), centre_xy.y(), half.z());
  EXPECT_LT((box.centre_mm - true_centre).norm(), kVoxel) << box.centre_mm.transpose();
  EXPECT_NEAR(box.size_mm.x(), kBoxSize.x(), kVoxel);
  EXPECT_NEAR(box.size_mm.y(), kBoxSize.y(), kVoxel);
  EXPECT_NEAR(box.size_mm.z(), kBoxSize.z(), kVoxel);
  EXPECT_NEAR(box.yaw_rad, kBoxYaw, 1 * kDeg);
  EXPECT_GT(used, 1000);
  EXPECT_LT(50.0 / on_box, 0.01);  // the fuzz is under 1 % of the voxels

  const TargetBox untouched = box;
  TargetBox far = near;
  far.centre_mm += Eigen::Vector3d(400, 0, 0);
  EXPECT_FALSE(BoxFromModel(voxels, kVoxel, floor, far, &box, &used, &why));
  EXPECT_NE(why.find("outside"), std::string::npos) << why;
  EXPECT_EQ(used, 0);
  const std::vector<Eigen::Vector3d> few(voxels.end() - 40, voxels.end());
  EXPECT_FALSE(BoxFromModel(few, kVoxel, floor, near, &box, &used, &why));
  EXPECT_NE(why.find("no connected group"), std::string::npos) << why;
  EXPECT_FALSE(BoxFromModel(voxels, 0, floor, near, &box, &used, &why));
  EXPECT_FALSE(BoxFromModel({}, kVoxel, floor, near, &box, &used, &why));
  EXPECT_EQ(box.centre_mm, untouched.centre_mm);
}

TEST(ObjectFinderTest, InvalidOptionsThrow) {
  ObjectFinderOptions o;
  o.target_max_size_mm = 50;  // below the minimum
  std::string why;
  EXPECT_FALSE(ValidateObjectFinderOptions(o, &why));
  EXPECT_NE(why.find("target-max-size"), std::string::npos);
  EXPECT_THROW(ObjectFinder{o}, std::invalid_argument);
  EXPECT_TRUE(ValidateObjectFinderOptions(ObjectFinderOptions{}, &why));
}

}  // namespace
}  // namespace objscan
