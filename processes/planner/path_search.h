// Shortest paths on the OccupancyMap (8-connected cells), LCM-free.
// Step cost = step length (mm) x (1 + clearance_weight * max(0, 1 - obstacle distance / preferred_clearance_mm)), so
// paths keep away from obstacles where there is room; cells that are only Passable (closer than the inflated radius:
// the robot may have to leave such a spot) cost passable_cost_factor times more. Searches expand into Traversable
// and Passable cells only; the start cell is always expanded (the robot stands there). Paths are lists of points (mm,
// world) from the start position to the goal cell's centre.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "processes/planner/occupancy_map.h"

namespace objscan {

struct PathSearchOptions {
  double clearance_weight = 2.0;         // extra cost factor right at the inflated radius
  double preferred_clearance_mm = 700;   // mm, obstacle distance from which on the extra cost is 0
  double passable_cost_factor = 4.0;     // cost factor of Passable-only cells
};

// Dijkstra from a start to every reachable cell.
class CostField {
 public:
  void Compute(const OccupancyMap& map, const Eigen::Vector2d& start, const PathSearchOptions& options = {});
  bool Reachable(int index) const { return index >= 0 && index < static_cast<int>(cost_.size()) && cost_[index] < kUnreached; }
  double CostMm(int index) const { return cost_[index]; }
  // Points from the start position to the centre of cell `index` (empty when unreachable).
  std::vector<Eigen::Vector2d> PathTo(const OccupancyMap& map, int index) const;
  int start_index() const { return start_index_; }
  bool valid() const { return start_index_ >= 0; }

  static constexpr double kUnreached = 1e300;

 private:
  std::vector<double> cost_;
  std::vector<int> parent_;
  int start_index_ = -1;
  Eigen::Vector2d start_ = Eigen::Vector2d::Zero();
};

// A* from start to the cell of goal. False when the goal is outside the map, not Traversable or not reachable.
bool PlanPath(const OccupancyMap& map, const Eigen::Vector2d& start, const Eigen::Vector2d& goal,
              std::vector<Eigen::Vector2d>* path, double* cost_mm = nullptr, const PathSearchOptions& options = {});

// Length (mm) of a polyline.
double PathLength(const std::vector<Eigen::Vector2d>& path);

}  // namespace objscan
