#include "processes/tracker/tracking_mode.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <thread>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "processes/tracker/descriptor_seeding.h"

namespace objscan {
namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace

TrackingModeProbe ProbeTrackingMode(const std::vector<cv::Mat>& frames, const KltTrackerOptions& klt,
                                    double min_kept) {
  TrackingModeProbe probe;
  if (frames.size() < 2) {
    probe.detail = "fewer than 2 frames: nothing to measure, KLT";
    return probe;
  }
  KltTracker tracker(klt);
  std::vector<double> kept, flow;
  std::map<int64_t, cv::Point2f> previous;
  for (size_t i = 0; i < frames.size(); ++i) {
    std::map<int64_t, cv::Point2f> current;
    try {
      ImageFrame frame;
      frame.seq = static_cast<int64_t>(i);
      frame.image = frames[i];
      for (const TrackedFeature& f : tracker.Track(frame).features) current[f.id] = cv::Point2f(f.u, f.v);
    } catch (const std::invalid_argument&) {
      tracker.Reset();  // unusable frame: this pair and the next keep nothing
    }
    if (i > 0) {
      std::vector<cv::Point2f> from, to;
      for (const auto& kv : current) {
        auto it = previous.find(kv.first);
        if (it != previous.end()) { from.push_back(it->second); to.push_back(kv.second); }
      }
      double fraction = 0, pair_flow = 0;
      if (from.size() >= 8) {
        cv::setRNGSeed(1);
        std::vector<uchar> inlier;
        cv::Mat F = cv::findFundamentalMat(from, to, cv::FM_RANSAC, 1.5, 0.999, inlier);
        std::vector<double> moved;
        if (!F.empty()) {
          for (size_t j = 0; j < inlier.size(); ++j)
            if (inlier[j]) moved.push_back(std::hypot(to[j].x - from[j].x, to[j].y - from[j].y));
        }
        fraction = static_cast<double>(moved.size()) / static_cast<double>(previous.size());
        pair_flow = Median(moved);
      }
      kept.push_back(fraction);
      flow.push_back(pair_flow);
    }
    previous = std::move(current);
  }
  probe.pairs = static_cast<int>(kept.size());
  probe.median_kept = Median(kept);
  probe.median_flow_px = Median(flow);
  probe.wide_baseline = probe.median_kept < min_kept;
  char line[256];
  std::snprintf(line, sizeof line, "KLT keeps %.0f %% of the tracks between consecutive frames (median of %d pairs, "
                "median flow %.1f px; below %.0f %% is wide baseline): %s", 100 * probe.median_kept, probe.pairs,
                probe.median_flow_px, 100 * min_kept, probe.wide_baseline ? "descriptor tracking" : "KLT");
  probe.detail = line;
  return probe;
}

ViewOrder OrderViewsByOverlap(const std::vector<cv::Mat>& frames) {
  ViewOrder result;
  const int n = static_cast<int>(frames.size());
  DescriptorTrackerOptions options;  // the tracker's own detection, matching and verification (default options),
  options.threads = std::max(1u, std::thread::hardware_concurrency());  // on every core: nothing else runs yet
  DescriptorTracker describer(options);
  std::vector<DescriptorTracker::DescribedImage> views(n);
  for (int i = 0; i < n; ++i) {
    try {
      views[i] = describer.DescribeImage(frames[i]);
    } catch (const std::invalid_argument&) {
      // unusable frame: no keypoints, it matches nothing
    }
  }
  std::vector<std::vector<int>> w(n, std::vector<int>(n, 0));  // verified matches between views i and j
  std::vector<uchar> inlier;
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      cv::setRNGSeed(1);
      describer.VerifiedMatches(views[i].points, views[i].descriptors, views[j].points, views[j].descriptors, &inlier);
      w[i][j] = w[j][i] = inlier.empty() ? 0 : cv::countNonZero(inlier);
    }
  }
  auto weakest = [&](const std::vector<int>& order, std::vector<int>* links) {
    int lo = n >= 2 ? std::numeric_limits<int>::max() : 0;
    if (links) links->clear();
    for (size_t k = 1; k < order.size(); ++k) {
      lo = std::min(lo, w[order[k - 1]][order[k]]);
      if (links) links->push_back(w[order[k - 1]][order[k]]);
    }
    return lo;
  };
  std::vector<int> natural(n);
  for (int i = 0; i < n; ++i) natural[i] = i;
  result.natural_weakest_link = weakest(natural, nullptr);
  // Greedy chain from the strongest pair.
  std::deque<int> chain;
  std::vector<bool> used(n, false);
  int bi = 0, bj = n > 1 ? 1 : 0, best = -1;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      if (w[i][j] > best) { best = w[i][j]; bi = i; bj = j; }
  if (n > 0) { chain.push_back(bi); used[bi] = true; }
  if (n > 1) { chain.push_back(bj); used[bj] = true; }
  while (static_cast<int>(chain.size()) < n) {
    int best_view = -1, best_w = 0;
    bool at_front = false;
    for (int v = 0; v < n; ++v) {
      if (used[v]) continue;
      if (w[chain.back()][v] > best_w) { best_w = w[chain.back()][v]; best_view = v; at_front = false; }
      if (w[chain.front()][v] > best_w) { best_w = w[chain.front()][v]; best_view = v; at_front = true; }
    }
    if (best_view < 0) break;  // the rest match neither end
    used[best_view] = true;
    if (at_front) chain.push_front(best_view); else chain.push_back(best_view);
  }
  std::vector<int> order(chain.begin(), chain.end());
  for (int v = 0; v < n; ++v)
    if (!used[v]) order.push_back(v);
  std::vector<int> links;
  const int chain_weakest = weakest(order, &links);
  if (order != natural && chain_weakest > result.natural_weakest_link) {
    result.order = order;
    result.links = links;
    result.weakest_link = chain_weakest;
    result.reordered = true;
  } else {
    result.order = natural;
    result.weakest_link = weakest(natural, &result.links);
  }
  char line[256];
  std::snprintf(line, sizeof line, "%d views: weakest link %d verified matches in the given order, %d in the best "
                "chain: %s", n, result.natural_weakest_link, chain_weakest,
                result.reordered ? "views reordered along the chain" : "given order kept");
  result.detail = line;
  return result;
}

}  // namespace objscan
