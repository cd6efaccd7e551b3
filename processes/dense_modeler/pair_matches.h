// Extra feature matches of one dense pair where the tracker left the object bare (LCM-free).
// The dense pair triangulates the features tracked in both views; where the tracker lost its tracks (a texture that
// turns and foreshortens as the robot circles it, e.g. an object's flat top seen at a grazing angle) there are no
// triangles and no dense points. AddPairMatches detects corners (Shi-Tomasi) of view A inside a pixel rectangle
// (the region's projected box, DensePairRoi) farther than min_track_distance_px from every tracked feature, follows
// them into view B with pyramidal Lucas-Kanade (started where the corner's ray meets the range of the nearest
// tracked features) and back (started as far from the corner as the forward pass moved, so a jump of a texture
// period shows), and keeps a corner when
//   - the backward track returns within max_backward_error_px of it and LK's window residual in B is at most
//     max_residual; corners farther than bare_distance_px from every tracked feature ("bare": the tracker has
//     nothing there, and the dense pair's per-pixel refinement corrects a rough vertex) need only
//     bare_max_backward_error_px and have no residual limit;
//   - its match lies within max_epipolar_px of its epipolar line in B.
// Corners among floor tracks (skip_floor_corners) are not followed at all.
// The two views are only a pair gap apart, so a match needs no track's long-term history. Frames/units: pixels
// (u, v) = (column, row), origin at the centre of the top-left pixel; poses world_from_camera (mm). Blocking; runs
// on the calling thread (plus OpenCV's threads when cv::setNumThreads allows). Never throws: bad input (images of
// different types, not 8-bit gray or BGR, not of their cameras' sizes; invalid cameras or options; non-finite or
// coincident poses; a rectangle smaller than the LK window) gives no matches; non-finite tracked matches are ignored.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "processes/dense_modeler/affine_dense.h"

namespace objscan {

struct PairMatchOptions {
  bool enabled = true;                  // add matches at all (read by the caller: the dense modeler node)
  int max_corners = 400;                // corners detected in A per pair at most (>= 1)
  double corner_quality = 0.01;         // Shi-Tomasi quality level, relative to the best corner away from the
                                        // tracked features in the rectangle, (0, 1)
  double min_distance_px = 6.0;         // px, between new corners, (0, 1000]
  double min_track_distance_px = 12.0;  // px, from every tracked feature: only where the tracker left a gap, (0, 1000]
  int window_px = 15;                   // px, side of the LK window (odd, >= 5); 11 px doubled the sim's mesh max
  int pyramid_levels = 3;               // LK pyramid levels above the image (0..6)
  int lk_max_iterations = 20;           // LK iterations per level at most, [1, 100] (30 took 19 % longer, same matches)
  double lk_epsilon_px = 0.03;          // px, LK stops when its step is smaller, (0, 1)
  double max_backward_error_px = 0.1;   // px, max distance of the B -> A track from the corner (> 0)
  double max_residual = 8.0;            // gray levels, max mean |A - B| over the LK window at the match (> 0)
  double bare_distance_px = 16.0;       // px, corners this far from every tracked feature are bare (see the top),
                                        // [min_track_distance_px, 1000]
  double bare_max_backward_error_px = 0.2;  // px, bare corners' backward limit (no residual limit), >=
                                            // max_backward_error_px
  double max_epipolar_px = 0.5;         // px, max distance of the match from the corner's epipolar line in B (> 0)
  bool skip_floor_corners = true;       // corners whose guess_neighbours nearest tracked features all lie on the
                                        // region's floor (under half its clearance) are not matched: the dense pair
                                        // skips floor triangles (AffineDenseOptions::skip_floor_triangles), and 55 %
                                        // of a sim pair's corners were floor
  int guess_neighbours = 4;             // nearest tracked features whose median range along A's rays starts LK
                                        // (0 = start at A's pixel; no floor test then)
};

// True when usable; otherwise false with *why set.
bool ValidatePairMatchOptions(const PairMatchOptions& options, std::string* why);

// Counters of one call (corners = skipped_floor + lost + rejected_* + added).
struct PairMatchStats {
  int corners = 0;            // corners detected in A
  int skipped_floor = 0;      // on the floor (skip_floor_corners), not matched
  int lost = 0;               // LK failed either way or left an image
  int rejected_backward = 0;  // backward track too far from the corner
  int rejected_residual = 0;  // LK window residual over max_residual
  int rejected_epipolar = 0;  // match too far from the epipolar line
  int added = 0;              // matches returned
};

// New matches (A's corner, B's match) for the pair; tracked: the matches the tracker gave (not repeated in the
// output). region: its floor for skip_floor_corners (an invalid region: no floor test). rect: pixels of A to look in
// (clipped to the image; empty = whole image: a caller with a region whose DensePairRoi is empty has nothing to add).
std::vector<PointMatch> AddPairMatches(const DenseView& a, const DenseView& b, const std::vector<PointMatch>& tracked,
                                       const cv::Rect& rect, const RegionOfInterest& region,
                                       const PairMatchOptions& options, PairMatchStats* stats = nullptr);

}  // namespace objscan
