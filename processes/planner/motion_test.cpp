// The trail primitives of motion.h: TrailBack, FollowTrail (forward and backing up), StaysOnTrail.
#include "processes/planner/motion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace objscan {
namespace {

constexpr double kDeg = M_PI / 180.0;

// An arc the robot drove: 20 points 50 mm apart turning left by 2 deg per point, from (0, 0) heading +x.
std::vector<Eigen::Vector2d> DrivenArc() {
  std::vector<Eigen::Vector2d> path{{0, 0}};
  double heading = 0;
  for (int i = 0; i < 20; ++i) {
    heading += 2 * kDeg;
    path.push_back(path.back() + 50 * Eigen::Vector2d(std::cos(heading), std::sin(heading)));
  }
  return path;
}

double Length(const std::vector<Eigen::Vector2d>& line) {
  double length = 0;
  for (size_t i = 1; i < line.size(); ++i) length += (line[i] - line[i - 1]).norm();
  return length;
}

TEST(TrailTest, TrailBackWalksTheNewestPointsBackToTheRequestedLength) {
  const std::vector<Eigen::Vector2d> path = DrivenArc();
  const Eigen::Vector2d here = path.back() + Eigen::Vector2d(10, 0);
  const std::vector<Eigen::Vector2d> trail = TrailBack(path, here, 300, 150);
  ASSERT_GE(trail.size(), 2u);
  EXPECT_EQ(trail.front(), here);
  EXPECT_GE(Length(trail), 300.0);
  EXPECT_LE(Length(trail), 360.0);
  EXPECT_EQ(trail[1], path.back());  // newest first
}

TEST(TrailTest, TrailBackStopsAtAJumpAndIsEmptyWhenTooShort) {
  std::vector<Eigen::Vector2d> path = DrivenArc();
  // A relocalization jump of 400 mm three points before the end: only 100 mm of trail behind the jump.
  for (size_t i = path.size() - 2; i < path.size(); ++i) path[i] += Eigen::Vector2d(0, 400);
  EXPECT_TRUE(TrailBack(path, path.back(), 300, 150).empty());
  const std::vector<Eigen::Vector2d> shorter = TrailBack(path, path.back(), 300, 40);
  EXPECT_NEAR(Length(shorter), 50.0, 1.0);  // the trail ends at the jump
  EXPECT_TRUE(TrailBack({}, {0, 0}, 300, 1).empty());
}

// Drives the unicycle with FollowTrail to the trail's end; returns the largest distance from the trail on the way.
double Drive(BasePose* base, const std::vector<Eigen::Vector2d>& trail, bool reverse, int* frames) {
  double worst = 0;
  bool reached = false;
  for (*frames = 0; *frames < 600; ++*frames) {
    const Velocity v = FollowTrail(*base, trail, reverse, 100, 30 * kDeg, &reached);
    if (reached) break;
    if (reverse) EXPECT_LE(v.v_mm_s, 0.0);
    if (!reverse) EXPECT_GE(v.v_mm_s, 0.0);
    *base = Integrate(*base, v, 1.0 / 30);
    double nearest = 1e9;
    for (size_t i = 1; i < trail.size(); ++i) {
      const Eigen::Vector2d a = trail[i - 1], ab = trail[i] - a;
      const double t = std::clamp((base->position() - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
      nearest = std::min(nearest, (a + t * ab - base->position()).norm());
    }
    worst = std::max(worst, nearest);
  }
  EXPECT_TRUE(reached);
  return worst;
}

TEST(TrailTest, FollowTrailBacksUpAlongTheArcAndDrivesBack) {
  const std::vector<Eigen::Vector2d> path = DrivenArc();
  // At the arc's end, heading along it (40 deg), as the robot that drove it.
  BasePose base;
  base.x_mm = path.back().x();
  base.y_mm = path.back().y();
  base.theta_rad = 40 * kDeg;
  const std::vector<Eigen::Vector2d> back = TrailBack(path, base.position(), 400, 150);
  int frames = 0;
  const double off_back = Drive(&base, back, true, &frames);
  EXPECT_LT(off_back, 15.0);
  EXPECT_LT((base.position() - back.back()).norm(), 41.0);
  EXPECT_NEAR(WrapAngle(base.theta_rad - 40 * kDeg) / kDeg, -16.0, 6.0);  // the heading followed the arc back
  EXPECT_LT(frames, 30 * 8);  // 400 mm at <= 100 mm/s, slowing at the end
  const std::vector<Eigen::Vector2d> forth(back.rbegin(), back.rend());
  const double off_forth = Drive(&base, forth, false, &frames);
  EXPECT_LT(off_forth, 15.0);
  EXPECT_LT((base.position() - path.back()).norm(), 41.0);
}

TEST(TrailTest, StaysOnTrailOnlyAlongIt) {
  const std::vector<Eigen::Vector2d> trail{{0, 0}, {-100, 0}, {-200, 0}, {-300, 0}};
  BasePose base;  // at the origin, heading +x: backing up follows the trail
  EXPECT_TRUE(StaysOnTrail(trail, base, {-100, 0}, 0.5, 60));
  EXPECT_FALSE(StaysOnTrail(trail, base, {100, 0}, 0.5, 20));   // forward leaves it after 20 mm
  EXPECT_FALSE(StaysOnTrail(trail, base, {-100, 1.0}, 1.0, 20));  // a curve off it
  EXPECT_FALSE(StaysOnTrail({}, base, {-100, 0}, 0.5, 60));
  base.theta_rad = M_PI / 2;  // sideways to it: backing up leaves it
  EXPECT_FALSE(StaysOnTrail(trail, base, {-100, 0}, 0.5, 30));
}

// Drives the detector for `seconds` at 30 Hz with the given command; the odometry follows the command times `follow`
// (1 = the base moves as asked, 0 = it stands). Returns the number of contacts felt.
int DriveContact(ContactDetector* d, double v_mm_s, double omega_rad_s, double seconds, double follow,
                 Eigen::Vector2d* odometry, double* heading, int64_t* now_us) {
  int contacts = 0;
  const double dt = 1.0 / 30;
  for (int i = 0; i < static_cast<int>(std::lround(seconds * 30)); ++i) {
    *odometry += follow * v_mm_s * dt * Eigen::Vector2d(std::cos(*heading), std::sin(*heading));
    *heading += follow * omega_rad_s * dt;
    *now_us += 33333;
    contacts += d->Update(v_mm_s, *heading, *odometry, dt, *now_us) ? 1 : 0;
  }
  return contacts;
}

TEST(ContactDetectorTest, ABaseHeldWhileDrivenIsAContactOnceASecond) {
  ContactDetector d;
  Eigen::Vector2d odometry(0, 0);
  double heading = 0;
  int64_t now = 0;
  EXPECT_EQ(DriveContact(&d, 80, 0, 2.5, 0.0, &odometry, &heading, &now), 2);
  EXPECT_NEAR(d.expected_mm(), 80, 5);
  EXPECT_LT(d.moved_mm(), 1);
  EXPECT_EQ(DriveContact(&d, 80, 0, 3, 1.0, &odometry, &heading, &now), 0);  // free again
  EXPECT_EQ(DriveContact(&d, 80, 0, 1.5, 0.1, &odometry, &heading, &now), 1);  // slipping at 10 %
}

// room_06: the look-around shuttle backed up at 23 mm/s while turning at 30 deg/s, then drove forward at 71 mm/s,
// within one second: the base moved as asked, no contact.
TEST(ContactDetectorTest, BackingUpThenDrivingOnIsNoContact) {
  ContactDetector d;
  Eigen::Vector2d odometry(2836, -1053);
  double heading = -0.71;
  int64_t now = 0;
  int contacts = DriveContact(&d, -23, -0.52, 0.9, 1.0, &odometry, &heading, &now);
  contacts += DriveContact(&d, 71, 0.32, 0.4, 1.0, &odometry, &heading, &now);
  contacts += DriveContact(&d, -40, 0, 0.5, 1.0, &odometry, &heading, &now);
  contacts += DriveContact(&d, 40, 0, 0.6, 1.0, &odometry, &heading, &now);
  EXPECT_EQ(contacts, 0);
  // An arc of small radius (23 mm/s at 30 deg/s) moved as asked: no contact either.
  EXPECT_EQ(DriveContact(&d, 23, 0.52, 3, 1.0, &odometry, &heading, &now), 0);
}

}  // namespace
}  // namespace objscan
