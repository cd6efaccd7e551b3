// Chooses how an image stream is tracked, from its first frames (LCM-free): KLT when consecutive frames are close
// enough for it (video rate), descriptor tracking when they are not (a sparse ring or turntable, 10+ deg between
// views). `objscan run --dataset` runs this on the dataset before it starts the processes, so the Middlebury rings
// and other wide-baseline sets need no flag (`--wide-baseline` / `--klt` force one mode).
//
// The measure: default KLT (the tracker's own options) runs over the first frames; for each consecutive pair the
// fraction of frame k's tracks that KLT follows into frame k+1 AND that agree with one epipolar geometry (RANSAC
// fundamental matrix, 1.5 px) is "kept". At video rate nearly all are kept (simulator orbit 0.95 and more); across
// a 20 deg step KLT follows few points, and those it does follow are mostly wrong. The median over the pairs decides.
// Deterministic (fixed RANSAC seed). Does not throw: unusable frames (empty, size changes) count as a pair with
// nothing kept.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "processes/tracker/klt_tracker.h"

namespace objscan {

struct TrackingModeProbe {
  int pairs = 0;               // consecutive frame pairs measured
  double median_kept = 0;      // median over the pairs of the kept fraction (see above), [0, 1]
  double median_flow_px = 0;   // px, median over the pairs of the kept tracks' median displacement
  bool wide_baseline = false;  // median_kept < min_kept: descriptor tracking
  std::string detail;          // one line: the figures and the choice
};

// frames: the stream's first frames in stream order (CV_8UC1 or CV_8UC3; 2 to about 8 are enough).
// min_kept: the kept fraction below which the stream is wide-baseline (0, 1). With fewer than 2 frames the result
// has pairs = 0 and wide_baseline = false (nothing to measure; KLT is the default).
TrackingModeProbe ProbeTrackingMode(const std::vector<cv::Mat>& frames, const KltTrackerOptions& klt = {},
                                    double min_kept = 0.5);

// View order of a wide-baseline image set whose file order need not be the order around the object (the Middlebury
// sparse rings: files in capture order, views scattered around the ring). Every pair of views is matched and verified
// as the descriptor tracker does it (DescriptorTracker::DescribeImage / VerifiedMatches, default options); the chain
// is grown greedily from the strongest pair, each step adding the unused view with the most verified matches to
// either end. Views that match nothing come last.
struct ViewOrder {
  std::vector<int> order;          // 0-based indices into frames, in chain order
  std::vector<int> links;          // verified matches between consecutive views of order (order.size() - 1)
  int weakest_link = 0;            // min of links (0 when fewer than 2 views)
  int natural_weakest_link = 0;    // the same for the given order (0, 1, 2, ...)
  bool reordered = false;          // order differs from the given one and its weakest link is stronger
  std::string detail;              // one line: the figures and the choice
};

// frames: the whole set (CV_8UC1 or CV_8UC3; pairs grow with the square of the count, about 15 ms each with 1500
// keypoints). Keeps the given order (reordered = false) unless the chain's weakest link is stronger than the given
// order's. Does not throw: empty frames match nothing.
ViewOrder OrderViewsByOverlap(const std::vector<cv::Mat>& frames);

}  // namespace objscan
