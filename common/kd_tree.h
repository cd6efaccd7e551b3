// KdTree: exact nearest-neighbour distance over a fixed set of 3-D points, for queries at any distance (a model that
// is centimetres off its truth costs O(log n) per query, where a grid's ring search degrades to brute force).
// The tree copies the points. Distances share the points' unit (mm here). Never throws beyond std::bad_alloc.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace objscan {

class KdTree {
 public:
  // Non-finite points are left out.
  explicit KdTree(const std::vector<Eigen::Vector3d>& points);
  // Distance from q to the nearest point; +inf for an empty tree or a non-finite q.
  double NearestDistance(const Eigen::Vector3d& q) const;
  bool empty() const { return points_.empty(); }

 private:
  struct Node {
    int begin = 0, end = 0;     // points_[begin, end) below this node
    int axis = -1;              // split axis, -1 for a leaf
    double split = 0;           // points_[begin, mid) have coordinate <= split, [mid, end) >= split
    int left = -1, right = -1;  // children (nodes_ indices)
  };
  int Build(int begin, int end);
  std::vector<Eigen::Vector3d> points_;
  std::vector<Node> nodes_;
};

}  // namespace objscan
