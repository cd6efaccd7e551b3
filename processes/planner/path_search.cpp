#include "processes/planner/path_search.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <queue>
#include <utility>

namespace objscan {
namespace {

constexpr int kDx[8] = {1, -1, 0, 0, 1, 1, -1, -1};
constexpr int kDy[8] = {0, 0, 1, -1, 1, -1, 1, -1};
constexpr double kStep[8] = {1, 1, 1, 1, M_SQRT2, M_SQRT2, M_SQRT2, M_SQRT2};

double StepCost(const OccupancyMap& map, int to, double length_mm, const PathSearchOptions& o) {
  const double d = map.ObstacleDistanceMm(to);
  const double extra = o.clearance_weight * std::max(0.0, 1.0 - d / o.preferred_clearance_mm);
  const double factor = map.Traversable(to) ? 1.0 : o.passable_cost_factor;
  return length_mm * (1.0 + extra) * factor;
}

using Entry = std::pair<double, int>;  // (priority, cell)

// Shared expansion of Dijkstra (heuristic 0) and A*. Stops when `goal` (>= 0) is settled.
void Search(const OccupancyMap& map, int start, int goal, const std::function<double(int)>& heuristic,
            const PathSearchOptions& o, std::vector<double>* cost, std::vector<int>* parent) {
  cost->assign(map.num_cells(), CostField::kUnreached);
  parent->assign(map.num_cells(), -1);
  std::vector<uint8_t> closed(map.num_cells(), 0);
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  (*cost)[start] = 0;
  open.push({heuristic(start), start});
  const double cell = map.cell_mm();
  while (!open.empty()) {
    const int current = open.top().second;
    open.pop();
    if (closed[current]) continue;
    closed[current] = 1;
    if (current == goal) return;
    const int x = map.XOf(current), y = map.YOf(current);
    for (int k = 0; k < 8; ++k) {
      const int nx = x + kDx[k], ny = y + kDy[k];
      if (nx < 0 || ny < 0 || nx >= map.width() || ny >= map.height()) continue;
      const int next = map.IndexAt(nx, ny);
      if (closed[next] || !map.Passable(next)) continue;
      if (k >= 4 && (!map.Passable(map.IndexAt(nx, y)) || !map.Passable(map.IndexAt(x, ny)))) continue;  // corners
      const double c = (*cost)[current] + StepCost(map, next, kStep[k] * cell, o);
      if (c < (*cost)[next]) {
        (*cost)[next] = c;
        (*parent)[next] = current;
        open.push({c + heuristic(next), next});
      }
    }
  }
}

std::vector<Eigen::Vector2d> Backtrack(const OccupancyMap& map, const std::vector<int>& parent, int start,
                                       const Eigen::Vector2d& start_position, int goal) {
  std::vector<Eigen::Vector2d> points;
  for (int c = goal; c >= 0 && c != start; c = parent[c]) points.push_back(map.CentreOf(c));
  points.push_back(start_position);
  std::reverse(points.begin(), points.end());
  return points;
}

}  // namespace

void CostField::Compute(const OccupancyMap& map, const Eigen::Vector2d& start, const PathSearchOptions& options) {
  start_ = start;
  start_index_ = -1;
  int index;
  if (!map.IndexOf(start, &index)) {
    cost_.assign(map.num_cells(), kUnreached);
    parent_.assign(map.num_cells(), -1);
    return;
  }
  start_index_ = index;
  Search(map, index, -1, [](int) { return 0.0; }, options, &cost_, &parent_);
}

std::vector<Eigen::Vector2d> CostField::PathTo(const OccupancyMap& map, int index) const {
  if (!Reachable(index)) return {};
  return Backtrack(map, parent_, start_index_, start_, index);
}

bool PlanPath(const OccupancyMap& map, const Eigen::Vector2d& start, const Eigen::Vector2d& goal,
              std::vector<Eigen::Vector2d>* path, double* cost_mm, const PathSearchOptions& options) {
  int s, g;
  if (!map.IndexOf(start, &s) || !map.IndexOf(goal, &g) || !map.Traversable(g)) return false;
  const Eigen::Vector2d goal_centre = map.CentreOf(g);
  std::vector<double> cost;
  std::vector<int> parent;
  Search(map, s, g, [&](int c) { return (map.CentreOf(c) - goal_centre).norm(); }, options, &cost, &parent);
  if (cost[g] >= CostField::kUnreached) return false;
  *path = Backtrack(map, parent, s, start, g);
  if (cost_mm) *cost_mm = cost[g];
  return true;
}

double PathLength(const std::vector<Eigen::Vector2d>& path) {
  double length = 0;
  for (size_t i = 1; i < path.size(); ++i) length += (path[i] - path[i - 1]).norm();
  return length;
}

}  // namespace objscan
