// ObjectFinder: finds the object to model in the pose solver's sparse map. LCM-free, plain structs (the node in
// object_finder_node.h converts messages), deterministic (seeded RANSAC, no timing, no hash-order dependence).
//
// Frames and units: world z up (the pose solver's world = the odometry frame at the start; its floor is near z = 0
// but is fitted, not assumed), mm, rad; camera optical frame x right, y down, z forward; pixels (u, v) = (column,
// row), origin at the top-left pixel's centre.
//
// Each Update (one per LANDMARKS message: the whole map at a keyframe, that keyframe's camera pose, intrinsics):
//  1. Landmarks with a non-finite position or error, or negative counts, are dropped (counted). A landmark is
//     "fresh" when its id is new or its num_observations grew since the previous update: it was seen again.
//  2. Floor: RANSAC + least squares (floor_plane.h) on all landmarks; the last good floor is kept when a fit fails.
//     Nothing else happens before the first floor (state SEARCHING).
//  3. Points well observed (num_observations >= min_observations, error <= max_reprojection_error_px and <=
//     max_point_error_ratio times the map's median error: no silhouette corners) with a height
//     above the floor in (min_height_mm, max_height_mm] are clustered (single linkage, cluster_distance_mm) and each
//     cluster (>= 3 points) gets a box in the floor frame (clusters.h): centre, yaw, extents, height, lowest point,
//     texture density.
//  4. Target rule: largest horizontal extent and height within [target_min_size_mm * (1 - size_tolerance),
//     target_max_size_mm * (1 + size_tolerance)], lowest point <= floor_contact_mm above the floor, at least
//     min_target_points members and min_texture_density members per 100 cm^2 of visible side area, a median
//     reprojection error at most max_error_ratio times the map's (not outline points only), and free space
//     around it: at most max(3, 10 %) other points higher than floor_contact_mm within clearance_mm of its box (the
//     noisy landmarks where an object meets the floor are no neighbours; sparse walls and pillars
//     break into target-sized pieces at cluster_distance_mm; their neighbours reject them). Pieces rejected as not
//     isolated, too few points, too small, too low or not on the floor are linked again at 2 * cluster_distance_mm
//     (with the points of no cluster): a group of two or more pieces that passes the rule and is isolated replaces
//     them (a sparsely seen target falls apart; walls' pieces merge into something too large and stay rejected).
//  5. Tracks follow clusters over updates (greedy one-to-one by horizontal centre distance <= track_match_distance_mm,
//     the confirmed target's track first, preferring an observed cluster).
//     A cluster is "in view" when its centre projects into the image in front of the camera, "observed" when at
//     least max(3, min(20, 10 %)) of its members are fresh (a large cluster seen again after the camera looked
//     away gets tens of new landmarks, its old tracks ended). A track records a view when its cluster passes the rule, is in
//     view and observed, and the camera is >= min_view_baseline_mm away from every view recorded before or sees it
//     from a direction >= min_view_bearing_deg apart. A track is "missed" in an update in which its box is in view
//     within max_view_distance_mm, no other cluster's box stands on the line of sight to it, and its cluster is
//     not observed (or gone).
//  6. Candidate: a track whose cluster passes the rule now, with >= 1 view and missed fewer than lost_after_updates
//     times in a row; or, seen only from afar, fails only the size limits by a little (look closer, options). Confirmable: a candidate with >= min_views views whose centre moved <= max_centre_motion_mm over
//     its last min_views passing views. Among several, the nearest to the robot (robot_xy_mm) wins, without a robot
//     position the most views (then most points, then oldest track).
//  7. States: SEARCHING (no candidate), CANDIDATE (the chosen candidate), CONFIRMED (latched: the track keeps
//     refining centre, size, yaw from later updates and gains confidence with views; another cluster never takes
//     over unless the target fails the rule in drop_after_rejections observed in-view updates in a row, which
//     drops it), LOST (confirmed, missed lost_after_updates times in a row; back to CONFIRMED when observed
//     passing the rule again). Leaving the view does not make a target LOST: only not seeing it where it should be.
// Phantom points never form a cluster (>= 3 points, min_target_points); a cluster seen from one view only never gets
// min_views views. Cost ~1.3 ms (CPU) per update for 5 000 landmarks (object_finder_benchmark).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

#include "processes/object_finder/clusters.h"
#include "processes/object_finder/floor_plane.h"

namespace objscan {

// Values equal target_t::STATE_*.
enum class TargetState : int8_t { kSearching = 0, kCandidate = 1, kConfirmed = 2, kLost = 3 };
const char* TargetStateName(TargetState state);  // "searching", "candidate", "confirmed", "lost"

struct ObjectFinderOptions {
  // floor
  double floor_inlier_mm = 15.0;     // mm, max |height| of a floor landmark
  double floor_max_tilt_deg = 10.0;  // deg, max angle of the floor normal from world z
  int min_floor_points = 40;         // floor landmarks needed to accept a (new) floor
  // points clustered
  int min_observations = 3;                // views a landmark needs to be used
  double max_reprojection_error_px = 2.0;  // px, worse landmarks are not used
  double min_height_mm = 10.0;             // mm, points at or below this height are floor
  double max_height_mm = 1500.0;           // mm, points above are ignored
  double cluster_distance_mm = 50.0;       // mm, linkage distance of the clustering
  // target rule
  double target_min_size_mm = 80.0;   // mm, smallest target (largest horizontal extent and height)
  double target_max_size_mm = 300.0;  // mm, largest target
  double size_tolerance = 0.15;       // fraction the measured sizes may exceed the range by (partial views)
  double floor_contact_mm = 30.0;     // mm, the lowest point must be at most this high: stands on the floor
  double clearance_mm = 150.0;        // mm, free space around a target: other landmarks above the floor within
                                      // this margin of its box make it a piece of something larger
  double min_texture_density = 1.0;   // landmarks per 100 cm^2 of the box's visible side area
  // Points of a textured surface are as consistent as the floor's; the corners an object's silhouette makes with
  // the background behind it slide as the view moves. A point above the floor whose reprojection error is above
  // max_point_error_ratio times the map's median (all usable landmarks', mostly the floor's; taken as at least
  // 0.05 px) is left out (room_05: a box's outer ring at 0.25-0.95 px against 0.04 px inside made 258 x 218 mm
  // measure 358 x 257 mm, too large); a cluster whose members' median is above max_error_ratio times it is
  // "outline only", an untextured object (room_10: a plain 142 mm sphere at 0.38-0.46 px against the map's
  // 0.058 px passed the density rule). A textured target seen from 3 m: 0.5-4.2x the map's, median 2.3x (room_07).
  double max_error_ratio = 3.0;
  double max_point_error_ratio = 5.0;
  int min_target_points = 15;         // landmarks a target needs
  // persistence
  double track_match_distance_mm = 100.0;  // mm, horizontal centre distance that continues a track
  int min_views = 3;                       // distinct views that confirm a target
  double min_view_baseline_mm = 150.0;     // mm, camera distance that makes a view distinct ...
  double min_view_bearing_deg = 10.0;      // deg, ... or direction change seen from the cluster
  double max_centre_motion_mm = 30.0;      // mm, centre stability over the last min_views views
  int lost_after_updates = 5;              // missed in-view updates before LOST (and before a candidate is dropped)
  double max_view_distance_mm = 3000.0;    // mm, farther targets are not expected to be seen (not missed)
  int drop_after_rejections = 5;           // observed in-view updates failing the rule that drop a confirmed target
  // look closer: landmarks triangulated only from afar make an object look larger (room_05: a 258 x 218 mm box
  // measured 359 x 250 mm from 2-3 m, its landmarks 20-30 mm outside its faces). An isolated cluster that fails
  // only the size limits, by at most look_closer_margin, and was never observed from nearer than
  // look_closer_beyond_mm is a candidate without views: the robot goes to look, and the rule decides from there.
  double look_closer_beyond_mm = 1500.0;  // mm
  double look_closer_margin = 0.25;       // fraction beyond the size range's upper end (after size_tolerance)
};

// True when usable; otherwise false with *why (all problems, "; "-separated).
bool ValidateObjectFinderOptions(const ObjectFinderOptions& options, std::string* why);

struct MapLandmark {
  int64_t id = 0;                                         // landmark id (track id)
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();  // world
  int num_observations = 0;                               // views observing it
  double reprojection_error_px = 0;                       // px, RMS
};

// Pinhole intrinsics without distortion (the region is a box outline: distortion does not matter at that scale).
struct FinderCamera {
  int width = 0, height = 0;  // px
  double fx = 0, fy = 0;      // px
  double cx = 0, cy = 0;      // px
  bool IsValid() const;       // positive finite size and focal lengths, finite principal point
};

struct FinderInput {
  int64_t utime = 0;                   // µs, capture time of the keyframe the map belongs to
  int64_t seq = 0;                     // its frame sequence number
  std::vector<MapLandmark> landmarks;  // the whole sparse map
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();  // mm, camera pose of that keyframe
  FinderCamera camera;
  bool has_robot_position = false;
  Eigen::Vector2d robot_xy_mm = Eigen::Vector2d::Zero();  // robot base in world, for "nearest first"
};

// A box about world z (target_t's convention): centre, extents along the yawed x, y and z axes.
struct TargetBox {
  Eigen::Vector3d centre_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d size_mm = Eigen::Vector3d::Zero();
  double yaw_rad = 0;
};

struct ImageRegion {
  int u = 0, v = 0, width = 0, height = 0;  // px; width = height = 0: not in the image
};

// The box's 8 corners projected into the camera (corners behind it are left out), bounding rectangle clamped to
// the image; zero size when no corner is in front or the rectangle misses the image.
ImageRegion ProjectBox(const TargetBox& box, const Eigen::Isometry3d& world_from_camera, const FinderCamera& camera);

// The target's box measured on its dense model rather than on its landmarks: the landmarks' box lay 29-47 mm off the
// truth on mesh targets whose model was within 1 mm (rooms 04, 07, 7 Dec: a cluster's sparse points are uneven over
// the object, more on the well-textured and well-seen sides). voxels_mm: the model's voxel centres (world, mm) of
// voxel_mm; floor: the floor in the same frame; near: the landmarks' box. The voxels more than one voxel above the
// floor are clustered (single linkage at 2.5 voxels) and the largest cluster is boxed as a landmark cluster is
// (FitClusterBox: footprint between the 1 % and 99 % quantiles, yaw of the minimum-area rectangle), its height from
// the floor to the 99 % quantile of the voxels' heights, centre at mid height. False with *why (box untouched) when
// voxel_mm is not positive, fewer than kMinModelVoxels voxels are left, or the cluster's centre lies outside near's
// footprint grown by half its size on each side (a model of something else). *voxels_used: the cluster's voxels (may
// be null).
constexpr int kMinModelVoxels = 50;
bool BoxFromModel(const std::vector<Eigen::Vector3d>& voxels_mm, double voxel_mm, const FloorPlane& floor,
                  const TargetBox& near, TargetBox* box, int* voxels_used, std::string* why);

struct ClusterReport {  // every cluster of the update (for logs and tests)
  int track_id = -1;
  ClusterBox box;
  bool passes = false;
  std::string rejection;  // why the rule rejects it: "too high", "too large", "too low", "too small",
                          // "not on the floor", "not isolated", "too few points", "untextured", "outline only"
                          // ("" when it passes)
  bool in_view = false;
  bool observed = false;
};

struct CandidateReport {
  int track_id = -1;
  TargetBox box;
  int points = 0;
  int views = 0;
  double distance_mm = -1;  // mm, horizontal distance to the robot (-1 without a robot position)
};

struct FinderResult {
  int64_t utime = 0, seq = 0;  // of the last accepted update
  TargetState state = TargetState::kSearching;
  int track_id = -1;           // track of the reported target (-1 when searching)
  TargetBox box;               // the target's box (zero when searching)
  double confidence = 0;       // 0..1: < 0.5 candidate, >= 0.5 confirmed and growing with views; halved when lost
  ImageRegion roi;             // box in the update's camera image
  int views = 0;               // distinct views of the target
  int points = 0;              // landmarks in the target's cluster
  int64_t confirmed_seq = -1;  // update (keyframe) that confirmed the current target, -1 when none
  int64_t confirmed_utime = 0;
  std::vector<CandidateReport> other_candidates;  // the other candidates, nearest (or best) first
  std::vector<ClusterReport> clusters;
  int candidates = 0;  // candidates including the target
  bool floor_valid = false;
  FloorPlane floor;
  int floor_points = 0;        // inliers of the floor in force
  int points_used = 0;         // well-observed landmarks above the floor that were clustered
  int points_inconsistent = 0; // landmarks above the floor left out for their error (max_point_error_ratio)
  double map_error_px = 0;     // px, the map's median reprojection error that max_error_ratio scales
  int rejected_landmarks = 0;  // dropped in this update (non-finite, negative counts)
  // Set only in the update that dropped a confirmed target: why (the rule's reason, in how many views in a row, the
  // box it had then), e.g. "too large in 5 views in a row (box 310x250x220 mm)".
  std::string drop_reason;
  // While CANDIDATE: why it is not confirmed yet, every unmet condition, "; "-separated, e.g. "2 of 3 views; centre
  // moved 49 mm over its last views (max 30); not observed in this update" ("" otherwise).
  std::string not_confirmed_why;
};

class ObjectFinder {
 public:
  // Throws std::invalid_argument on invalid options.
  explicit ObjectFinder(const ObjectFinderOptions& options = {});

  // Processes one map. Returns false (state unchanged, *error set) when the camera intrinsics are invalid or the
  // pose is not a finite rigid transform; bad landmarks are dropped and counted, an empty map is a valid update.
  bool Update(const FinderInput& input, std::string* error = nullptr);

  const FinderResult& result() const { return result_; }
  int updates() const { return updates_; }

 private:
  struct View {
    Eigen::Vector3d camera_mm;
    Eigen::Vector3d direction;  // unit, from the box centre to the camera
  };
  struct Track {
    int id = 0;
    ClusterBox box;          // the latest cluster's box
    ClusterBox passing_box;  // the latest box that passed the rule
    bool matched = false;    // a cluster continued it in this update
    bool passes = false;     // that cluster passes the rule
    bool seen = false;       // matched and observed (members seen again) in this update
    int cluster = -1;        // index into result_.clusters in this update
    int unmatched_updates = 0;
    int missed_run = 0;    // in-view updates in a row without an observation
    int rejected_run = 0;  // observed in-view updates in a row failing the rule
    std::string last_rejection;  // the rule's reason in the latest of those updates ("too large", ...)
    std::vector<View> views;
    std::vector<Eigen::Vector3d> recent_centres;  // centres of the last min_views passing views
    double nearest_seen_mm = std::numeric_limits<double>::infinity();  // nearest camera that observed it
    bool look_closer = false;  // fails only the size limits by a little and was only seen from afar (options)
  };
  struct Cluster {
    ClusterBox box;
    std::string rejection;
    bool in_view = false;
    bool observed = false;
    bool near_miss = false;  // isolated, fails only the size limits, by at most look_closer_margin
  };

  std::vector<char> CollectLandmarks(const FinderInput& input, std::vector<int>* valid);
  void UpdateFloor(const FinderInput& input, const std::vector<int>& valid);
  std::vector<Cluster> FindClusters(const FinderInput& input, const std::vector<int>& valid,
                                    const std::vector<char>& fresh);
  void MergeFragments(const std::vector<Eigen::Vector3d>& floor_points, const std::vector<double>& point_errors_px,
                      std::vector<int>* label, std::vector<std::vector<int>>* members,
                      std::vector<Cluster>* clusters) const;
  // The rule's first failing check ("" when it passes); size_scale widens the upper size limit.
  std::string CheckRule(const ClusterBox& box, double size_scale = 1.0) const;
  // Clustered points outside `members` within clearance_mm of the box (floor frame).
  int CountNeighbours(const std::vector<Eigen::Vector3d>& floor_points, const std::vector<int>& label, int cluster,
                      const ClusterBox& box) const;
  void MatchTracks(const std::vector<Cluster>& clusters);
  void UpdateTracks(const FinderInput& input, const std::vector<Cluster>& clusters);
  void UpdateTarget(const FinderInput& input);
  void FillResult(const FinderInput& input, const std::vector<Cluster>& clusters);
  bool InView(const Eigen::Vector3d& centre, const FinderInput& input, double max_distance) const;
  // True when the line of sight from the camera to `centre` passes through the box of a cluster other than `own`
  // (index into clusters, -1 = none): another object stands between them, so not seeing the target there is no miss.
  bool Occluded(const Eigen::Vector3d& centre, int own, const FinderInput& input,
                const std::vector<Cluster>& clusters) const;
  bool IsCandidate(const Track& track) const;
  bool IsConfirmable(const Track& track) const;
  // The unmet conditions of IsConfirmable for a candidate, in words (FinderResult::not_confirmed_why).
  std::string WhyNotConfirmable(const Track& track, const std::vector<Cluster>& clusters) const;
  // Index into tracks_ of the best of the tracks accepted by `accept` (nearest to the robot first), -1 if none.
  template <class Pred>
  int Best(const FinderInput& input, Pred accept) const;
  double Distance(const FinderInput& input, const Track& track) const;
  Track* FindTrack(int id);

  ObjectFinderOptions options_;
  FinderResult result_;
  std::unordered_map<int64_t, int> previous_observations_;  // landmark id -> num_observations of the last update
  bool floor_valid_ = false;
  FloorPlane floor_;
  int floor_points_ = 0;
  std::vector<Track> tracks_;  // in creation order (ids ascending)
  int next_track_id_ = 1;
  int target_id_ = -1;  // confirmed (latched) target's track, -1 when none
  bool target_lost_ = false;
  int64_t confirmed_seq_ = -1, confirmed_utime_ = 0;
  std::string drop_reason_;  // set by UpdateTarget when it drops the confirmed target (this update only)
  int updates_ = 0;
};

}  // namespace objscan
