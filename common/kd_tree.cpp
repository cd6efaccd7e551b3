#include "common/kd_tree.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace objscan {
namespace {
constexpr int kLeafSize = 8;
}  // namespace

KdTree::KdTree(const std::vector<Eigen::Vector3d>& points) {
  points_.reserve(points.size());
  for (const Eigen::Vector3d& p : points)
    if (p.allFinite()) points_.push_back(p);
  if (!points_.empty()) {
    nodes_.reserve(2 * points_.size() / kLeafSize + 2);
    Build(0, static_cast<int>(points_.size()));
  }
}

int KdTree::Build(int begin, int end) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.push_back(Node{begin, end});
  if (end - begin <= kLeafSize) return index;
  Eigen::Vector3d lo = points_[begin], hi = lo;
  for (int i = begin + 1; i < end; ++i) {
    lo = lo.cwiseMin(points_[i]);
    hi = hi.cwiseMax(points_[i]);
  }
  int axis = 0;
  (hi - lo).maxCoeff(&axis);
  if (!(hi[axis] > lo[axis])) return index;  // all points equal: one leaf
  const int mid = begin + (end - begin) / 2;
  std::nth_element(points_.begin() + begin, points_.begin() + mid, points_.begin() + end,
                   [axis](const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return a[axis] < b[axis]; });
  const double split = points_[mid][axis];
  const int left = Build(begin, mid);
  const int right = Build(mid, end);
  Node& node = nodes_[index];  // Build may have reallocated nodes_
  node.axis = axis;
  node.split = split;
  node.left = left;
  node.right = right;
  return index;
}

double KdTree::NearestDistance(const Eigen::Vector3d& q) const {
  double best2 = std::numeric_limits<double>::infinity();
  if (nodes_.empty() || !q.allFinite()) return std::sqrt(best2);
  // Depth-first, nearer child first; a far child is visited only when the split plane is nearer than the best.
  struct Pending {
    int node;
    double plane2;  // squared distance from q to the node's side of its parent's split plane (0: q's side)
  };
  Pending stack[128];
  int top = 0;
  stack[top++] = {0, 0.0};
  while (top > 0) {
    const Pending p = stack[--top];
    if (p.plane2 >= best2) continue;
    const Node& node = nodes_[p.node];
    if (node.axis < 0) {
      for (int i = node.begin; i < node.end; ++i) best2 = std::min(best2, (points_[i] - q).squaredNorm());
      continue;
    }
    const double d = q[node.axis] - node.split;
    const int near = d <= 0 ? node.left : node.right, far = d <= 0 ? node.right : node.left;
    stack[top++] = {far, std::max(p.plane2, d * d)};
    stack[top++] = {near, p.plane2};
  }
  return std::sqrt(best2);
}

}  // namespace objscan
