// OccupancyMap: the planner's own 2-D map of the floor in world (cells of cell_mm, a square of size_mm centred on the
// world origin = the robot's start), LCM-free.
//   obstacles  cells holding a sparse-map landmark between obstacle_min_z_mm and obstacle_max_z_mm above the local
//              floor (the mean height of the near-floor landmarks within about a metre; z = 0 where there are few)
//              (with >= min_observations views and <= max_error_px reprojection error); recomputed from each
//              landmark set (the pose solver sends its whole map at every keyframe, so a removed point clears).
//   seen       sticky: floor cells the camera's view rays reached (MarkView: inside the image, within
//              view_range_mm, not behind an obstacle cell) and cells holding a floor landmark (|z| <= floor_band_mm)
//              and their 8 neighbours, and the floor within kBesideFootprintMm beside the footprint wherever the
//              robot stood (it came there looking ahead, so the camera saw that floor on the way, although one
//              pose's view rays never reach the ring right around the robot; obstacles still win).
//   free       seen, no obstacle, and (free_support_mm > 0) a floor landmark within free_support_mm: a textured floor
//              seen there (an object standing there would have hidden it); free_support_mm = 0 lets the view rays
//              alone mark free space (untextured floors). Cells the robot stood on (MarkFootprint) are free. After a
//              map restart (RememberOldMap) the old map's floor landmarks support free space too, until an obstacle
//              of a later set lies in their cell.
//   unexplored unknown, or free only by the old map's floor (not stood on): free to drive through, but not seen by
//              the current map, whose landmarks the object finder clusters: frontiers lead there (Unexplored*).
//   unknown    everything else, and the map's border ring. Never driven through.
// Derived after Update(): distance to the nearest obstacle cell and to the nearest unknown cell (exact Euclidean
// distance transforms, between cell centres, mm), Traversable = free, >= footprint + safety margin from obstacles
// and >= footprint from unknown cells (the inflated map the paths use); FootprintSafe = the collision check of the
// round footprint: >= footprint + a cell diagonal from obstacle cells (landmark and robot may sit anywhere in their
// cells, so the footprint stays clear of every landmark) and >= footprint from unknown cells. Traversable implies
// FootprintSafe (the margin counts as at least a cell diagonal).
// Queries before the first Update() see an all-unknown map. Non-finite landmarks are skipped.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "processes/planner/planner_geometry.h"

namespace objscan {

constexpr double kBesideFootprintMm = 300;  // mm, see "seen" above

struct MapLandmark {
  Eigen::Vector3f position_mm = Eigen::Vector3f::Zero();  // mm, world
  int observations = 0;                                   // views that observe it
  float error_px = 0;                                     // px, RMS reprojection error
};

struct OccupancyMapOptions {
  double cell_mm = 50;               // mm, cell edge
  double size_mm = 16000;            // mm, side of the mapped square (centred on the world origin)
  double obstacle_min_z_mm = 30;     // mm, landmarks at least this high above the floor are obstacles
  double obstacle_max_z_mm = 1500;   // mm, ... and at most this high (higher ones do not block the base)
  double floor_band_mm = 30;         // mm, |z| within this = floor landmark
  int min_observations = 2;          // views a landmark needs to count
  double max_error_px = 3;           // px, largest RMS reprojection error of a landmark that counts
  double view_range_mm = 2500;       // mm, how far the view rays mark the floor seen
  double free_support_mm = 400;      // mm, free needs a floor landmark this close (0 = view rays suffice)
  double footprint_radius_mm = 200;  // mm, the robot's round footprint
  double safety_margin_mm = 100;     // mm, extra clearance of planned paths from obstacles
};

bool ValidateOccupancyMapOptions(const OccupancyMapOptions& options, std::string* why);

class OccupancyMap {
 public:
  enum class State : uint8_t { kUnknown = 0, kFree = 1, kOccupied = 2 };

  // Throws std::invalid_argument on invalid options.
  explicit OccupancyMap(const OccupancyMapOptions& options);

  void SetLandmarks(const std::vector<MapLandmark>& landmarks);
  // The landmarks are about to be replaced by those of a new map (the pose solver restarted it and has not joined
  // it to the old one): the obstacle cells so far stay obstacles ("remembered") until a later set has a floor
  // landmark in the cell (the floor visible there: nothing stands on it). An unjoined map lies a few cm off, but an
  // obstacle forgotten is worse than one misplaced (room_04: the approach drove into a crate the new map had not
  // seen yet, twice). The floor landmarks' cells keep supporting free space until a later set has an obstacle in
  // the cell: without them the free space shrank to the new map's first floor points and a candidate being looked
  // at had nowhere to be looked at from (room_10: its 4 places used up 0.2 s after a restart). That floor counts as
  // unexplored, so the search still goes over it again with the new map.
  void RememberOldMap();
  int remembered_cells() const { return remembered_cells_; }  // remembered obstacle cells not cleared yet
  void MarkView(const Eigen::Isometry3d& world_from_camera, const CameraIntrinsics& camera);
  void MarkFootprint(const Eigen::Vector2d& position_mm);
  // The base touched something here that the landmarks do not show (an untextured object has none): the cell is an
  // obstacle for the rest of the mission (no later landmark set clears it). Ignored outside the map.
  void MarkFelt(const Eigen::Vector2d& position_mm);
  int felt_cells() const { return felt_cells_; }
  // True when a felt cell's centre lies within radius_mm of p (mm, world).
  bool FeltWithin(const Eigen::Vector2d& p, double radius_mm) const;
  // Recomputes states and distance fields when an input changed since the last call.
  void Update();

  const OccupancyMapOptions& options() const { return options_; }
  int width() const { return size_; }
  int height() const { return size_; }
  int num_cells() const { return size_ * size_; }
  double cell_mm() const { return options_.cell_mm; }
  // Cell index of a point; false outside the map.
  bool IndexOf(const Eigen::Vector2d& p, int* index) const;
  Eigen::Vector2d CentreOf(int index) const;
  int IndexAt(int ix, int iy) const { return iy * size_ + ix; }
  int XOf(int index) const { return index % size_; }
  int YOf(int index) const { return index / size_; }

  State StateOf(int index) const { return state_[index]; }
  double ObstacleDistanceMm(int index) const { return obstacle_distance_[index]; }
  double UnknownDistanceMm(int index) const { return unknown_distance_[index]; }
  double UnexploredDistanceMm(int index) const { return unexplored_distance_[index]; }
  bool Seen(int index) const { return seen_[index] != 0; }
  double FloorLandmarkDistanceMm(int index) const { return floor_distance_[index]; }  // kept when support > 0
  bool Traversable(int index) const;
  bool Passable(int index) const;  // FootprintSafe at the cell centre (for leaving tight spots)
  double SafeObstacleDistanceMm() const;  // footprint + cell diagonal
  bool TraversableAt(const Eigen::Vector2d& p) const;
  bool FootprintSafe(const Eigen::Vector2d& p) const;
  // Unexplored cells in the square of half side radius_mm around a cell (summed-area table, O(1)).
  int UnexploredCellsNear(int index, double radius_mm) const;

  int obstacle_cells() const { return obstacle_cells_; }
  int free_cells() const { return free_cells_; }
  int obstacle_landmarks() const { return obstacle_landmarks_; }
  int floor_landmarks() const { return floor_landmarks_; }
  int64_t version() const { return version_; }  // increases whenever Update() changed something

 private:
  OccupancyMapOptions options_;
  int size_ = 0;      // cells per side
  double origin_ = 0; // mm, world x (= y) of the map's corner
  std::vector<uint8_t> seen_, stood_, obstacle_, floor_, remembered_, remembered_floor_, felt_;
  int felt_cells_ = 0;
  bool any_remembered_floor_ = false;
  int remembered_cells_ = 0;  // remembered obstacle cells not cleared yet
  std::vector<State> state_;
  std::vector<float> obstacle_distance_, unknown_distance_, unexplored_distance_, floor_distance_,
      remembered_floor_distance_;
  std::vector<int32_t> unexplored_sum_;  // summed-area table of unexplored cells, (size+1)^2
  bool landmarks_dirty_ = false, seen_dirty_ = false;
  int obstacle_cells_ = 0, free_cells_ = 0, obstacle_landmarks_ = 0, floor_landmarks_ = 0;
  int64_t version_ = 0;
};

// Squared Euclidean distance (in cells^2) of every cell of a w x h grid to the nearest site (Felzenszwalb &
// Huttenlocher 2012); without sites every value is a large number (>= 1e18).
void SquaredDistanceToSites(const std::vector<uint8_t>& is_site, int w, int h, std::vector<float>* squared);

}  // namespace objscan
