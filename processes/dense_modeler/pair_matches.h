// Extra feature matches of one dense pair where the tracker left the object bare (LCM-free).
// The dense pair triangulates the features tracked in both views; where the tracker lost its tracks (a texture that
// turns and foreshortens as the robot circles it, e.g. an object's flat top seen at a grazing angle) there are no
// triangles and no dense points. AddPairMatches detects corners (Shi-Tomasi) of view A inside a pixel rectangle
// (the region's projected box) farther than min_track_distance_px from every tracked feature, follows them into view B
// with pyramidal Lucas-Kanade (started where the corner's ray meets the range of the nearest tracked features), and
// keeps a corner only when LK from B back to A returns within max_backward_error_px of it, LK's window residual is at
// most max_residual and its match lies within max_epipolar_px of its epipolar line in B. The two views are only a pair
// gap apart, so a match needs no track's long-term history. Frames/units: pixels (u, v) = (column, row), origin at the
// centre of the top-left pixel; poses world_from_camera (mm). Blocking, single-threaded unless OpenCV threads are on;
// never throws for bad data (images of different types or sizes, invalid cameras, coincident centres, an empty
// rectangle give no matches).
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "processes/dense_modeler/affine_dense.h"

namespace objscan {

struct PairMatchOptions {
  bool enabled = true;                  // add matches at all
  int max_corners = 400;                // corners detected in A per pair at most (>= 1)
  double corner_quality = 0.01;         // Shi-Tomasi quality level, relative to the rectangle's best corner, (0, 1)
  double min_distance_px = 6.0;         // px, between new corners (> 0)
  double min_track_distance_px = 12.0;  // px, from every tracked feature: only where the tracker left a gap (> 0)
  int window_px = 15;                   // px, side of the LK window (odd, >= 5)
  int pyramid_levels = 3;               // LK pyramid levels above the image (0..6)
  double max_backward_error_px = 0.1;   // px, max distance of the B -> A track from the corner (> 0)
  double max_residual = 8.0;            // gray levels, max mean |A - B| over the LK window at the match (> 0)
  // Corners farther than bare_distance_px from every tracked feature lie where the tracker has nothing (there the
  // dense pair's per-pixel refinement corrects a rough vertex, and any match is better than none): they need only
  double bare_distance_px = 16.0;           // px (> 0)
  double bare_max_backward_error_px = 0.2;  // px, this backward error, and no residual limit (> 0)
  double max_epipolar_px = 0.5;             // px, max distance of the match from the corner's epipolar line in B (> 0)
  int guess_neighbours = 4;                 // nearest tracked features whose median range along A's rays starts LK
                                            // (0 = start at A's pixel)
};

bool ValidatePairMatchOptions(const PairMatchOptions& options, std::string* why);

struct PairMatchStats {
  int corners = 0;            // corners detected in A
  int lost = 0;               // LK failed either way or left an image
  int rejected_backward = 0;  // backward track too far from the corner
  int rejected_residual = 0;  // LK window residual over max_residual
  int rejected_epipolar = 0;  // match too far from the epipolar line
  int added = 0;              // matches returned
};

// New matches (A's corner, B's match) for the pair; tracked: the matches the tracker gave (not repeated in the
// output). rect: pixels of A to look in (clipped to the image; empty = whole image).
std::vector<PointMatch> AddPairMatches(const DenseView& a, const DenseView& b, const std::vector<PointMatch>& tracked,
                                       const cv::Rect& rect, const PairMatchOptions& options,
                                       PairMatchStats* stats = nullptr);

}  // namespace objscan
