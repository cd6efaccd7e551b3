// KLT feature tracker (LCM-free): Shi-Tomasi corners spread over a grid, pyramidal Lucas-Kanade (own
// implementation: translation, inverse compositional, float pyramid; motion prediction from the track's last
// displacement) with an optional forward-backward check, replenishment in cells below quota, persistent never-reused
// int64 track ids. With anchor_refine (default) LK only runs on the coarse pyramid levels (down to lk_stop_level) and
// the anchor alignment below does the base-level search, which is where the time goes (about 2.5 of 4.5 ms per frame
// for 1000 tracks at 640x480 on one core, see klt_tracker_benchmark).
// Drift-free positions (anchor_refine): every track keeps the image patch around it in its anchor frame (its birth
// frame, or the frame of its last re-anchoring). After frame-to-frame LK (which finds the large motion) the position
// is refined by aligning that reference template to the current image with an affine warp and gain/bias
// compensation (inverse-compositional Lucas-Kanade; the affine consistency check of Shi and Tomasi, "Good Features
// to Track", 1994). The error then no longer accumulates frame by frame; tracks whose template no longer matches
// (occlusion, non-planar structure, depth edges) are dropped.
//
// Pixel convention: (u, v) = (column, row), origin at the centre of the top-left pixel (the OpenCV convention of
// calcOpticalFlowPyrLK / cornerSubPix). Coordinates are those of the input (distorted) image.
// Not thread-safe; one instance per image stream. Deterministic: no random numbers, OpenCV thread count fixed by
// options.threads, output order = ascending track id.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "common/sensor_data.h"

namespace objscan {

struct KltTrackerOptions {
  int max_tracks = 1000;                // upper bound on live tracks in any frame
  int grid_cols = 16;                   // spatial grid columns over the image (detection quotas are per cell)
  int grid_rows = 12;                   // spatial grid rows
  int max_per_cell = 0;                 // live-track quota per grid cell; 0 = ceil(max_tracks / (cols * rows))
  int border_margin_px = 8;             // px, tracks closer than this to the image border are dropped / not born
  double min_distance_px = 8.0;         // px, a new corner must be at least this far from live tracks and new corners
  double duplicate_distance_px = 1.0;   // px, of two tracks closer than this the younger is dropped (0 = never)
  double quality_level = 0.01;          // Shi-Tomasi: response >= quality_level * strongest recent response (0, 1)
  double min_eigenvalue = 1e-4;         // Shi-Tomasi absolute floor on the response (cv::cornerMinEigenVal units)
  int corner_block_size = 3;            // px, Shi-Tomasi structure-tensor window (odd, >= 3)
  int subpix_half_window = 3;           // px, cornerSubPix half window for new corners (0 = no refinement)
  int detect_interval = 1;              // frames; detection runs every this many frames (always on the first)
  double min_cell_fill = 1.0;           // detect when a cell holds < min_cell_fill * quota tracks; (0, 1]; then all
                                        // cells below quota are topped up, emptiest first
  int win_size = 21;                    // px, Lucas-Kanade window side (odd, >= 5)
  int max_level = 2;                    // pyramid levels above the base image (0 = no pyramid)
  bool predict_motion = true;           // start LK at the position predicted by the track's last displacement
                                        // (new tracks: the median displacement of the previous frame); tracks
                                        // that fail from there are retried from zero motion
  int coarse_win_size = 7;              // px, window on pyramid levels >= 1 (odd, <= win_size; 0 = win_size there)
  int lk_stop_level = 2;                // pyramid level on which LK stops (0 = base image); above 0 the anchor
                                        // alignment does the base-level search from LK's estimate (the LK
                                        // checks then apply on that level); [0, max_level]; 0 without anchor_refine
  int max_iterations = 30;              // Lucas-Kanade iterations per level
  double epsilon = 0.01;                // px, Lucas-Kanade convergence threshold
  double lk_min_eigenvalue = 1e-4;      // (gray levels / px)^2, Lucas-Kanade: drop a point when the min eigenvalue
                                        // of its window's gradient matrix divided by the window's pixels is below
  bool forward_backward_check = false;  // track back from the new frame and drop points that do not come home
                                        // (off by default: the anchor alignment check rejects the same tracks)
  double fb_threshold_px = 0.5;         // px, max forward-backward round trip error
  double max_patch_error = 15.0;        // gray levels, max mean |difference| of the LK window after tracking (0 = off)
  int threads = 1;                      // cv::setNumThreads value set on every Track() call (>= 1)
  bool anchor_refine = true;            // refine every LK position by affine alignment of the track's anchor template
  int anchor_half_window = 7;           // px, anchor template half side: the template has (2h+1)^2 px; [2, 25]
                                        // (7: as accurate on the simulator orbit as 9, at 60 % of the cost)
  int anchor_max_iterations = 20;       // inverse-compositional iterations per track and frame (>= 1)
  double anchor_epsilon = 0.03;         // px, iterations stop when the update moves no template corner further
  double anchor_max_residual = 0.35;    // max RMS residual of the aligned template after gain/bias compensation,
                                        // relative to the template's own RMS contrast; worse tracks are dropped (0, 2]
  double anchor_reanchor_residual = 0.0;  // tracks whose alignment residual exceeds anchor_max_residual but stays
                                          // below this (same units) are kept at their LK position and re-anchored
                                          // there instead of being dropped (appearance changed faster than the
                                          // affine model follows; their error since the anchor is kept); 0 = never.
                                          // The default suits video-rate steps (simulator orbit: 1.8 deg/frame,
                                          // median residual ~0.19); wide-baseline steps (a 10 deg turntable, median
                                          // ~0.36) need e.g. 1.0 to keep tracks alive
  double anchor_max_shift_px = 2.0;    // px, max distance of the refined position from the LK position (else dropped)
  double anchor_max_distortion = 3.0;  // max scale change since the anchor in any direction (largest singular value
                                       // of the anchor -> current affine map, or inverse of the smallest); a track
                                       // beyond it is re-anchored (or dropped, see below); > 1
  bool use_avx2 = true;                // run the alignment's sampling and sums as AVX2 code when the CPU has it
                                       // (bit-identical results, about 1.3x faster; false = portable code only)
  bool anchor_reanchor = true;         // re-take the template in the current frame when the affine distortion gets
                                       // too large (each re-anchoring restarts the error from the current one);
                                       // false = drop such tracks
};

// Returns true when the options are usable; otherwise false with *why set.
bool ValidateKltTrackerOptions(const KltTrackerOptions& options, std::string* why);

// Figures of the most recent Track() call.
struct KltTrackStats {
  int live = 0;               // tracks in the returned frame
  int born = 0;               // new tracks in this frame (age 0)
  int lost = 0;               // tracks of the previous frame that were dropped
  bool detected = false;      // corner detection ran on this frame
  bool reset = false;         // the frame size changed (or first frame): all previous tracks were dropped
  double pyramid_ms = 0;      // ms (wall clock), gray conversion and pyramid
  double lk_ms = 0;           // ms (wall clock), Lucas-Kanade forward and backward passes and track culling
  double detect_ms = 0;       // ms (wall clock), corner detection and replenishment
  double refine_ms = 0;       // ms (wall clock), anchor template alignment (part of lk_ms)
  int anchor_rejected = 0;    // tracks dropped by the anchor alignment (residual, shift, border, no convergence)
  int reanchored = 0;         // tracks whose template was re-taken in this frame (distortion or residual)
  int anchor_aligned = 0;     // tracks whose anchor alignment ran in this frame
  int anchor_iterations = 0;  // alignment iterations of all tracks in this frame (each samples the whole template)
};

class KltTracker {
 public:
  // Throws std::invalid_argument when the options do not validate.
  explicit KltTracker(const KltTrackerOptions& options = {});

  // Tracks the live features into this frame (CV_8UC1 gray or CV_8UC3 BGR), replenishes, and returns every live
  // track with its position in this frame. utime/seq/camera_name are copied from the input. The first frame (or a
  // frame whose size differs from the previous one) only detects. Throws std::invalid_argument on an empty image
  // or another pixel type; the tracker state is unchanged then.
  TrackFrame Track(const ImageFrame& frame);

  // Drops every track (ids keep counting up; they are never reused).
  void Reset();
  // Before the first frame: the first track id (a tracker restarted mid-session starts above its predecessor's ids).
  void set_first_id(int64_t first_id) { next_id_ = first_id; }

  // Reference template of a track (opaque here; defined and used in the .cpp).
  struct Anchor;

  const KltTrackerOptions& options() const { return options_; }
  const KltTrackStats& last_stats() const { return stats_; }
  int64_t next_id() const { return next_id_; }
  int frames_processed() const { return frames_; }

 private:
  struct LiveTrack {
    int64_t id;
    cv::Point2f pt;                           // px, position in the last frame
    int32_t age;                              // frames since birth
    cv::Point2f velocity;                     // px/frame, last displacement (valid when age > 0)
    std::shared_ptr<const Anchor> anchor;     // template (null when anchor_refine is off)
    cv::Matx22f affine = cv::Matx22f::eye();  // linear part of the anchor -> last frame warp
  };
  int CellOf(const cv::Point2f& p) const;
  // Pyramidal LK of pts from one pyramid to the other (coarse-to-fine, see coarse_win_size), starting at
  // *initial when given (else at pts). *out, *status and *err get one entry per point (err: mean absolute
  // difference of the base-level window, gray levels).
  void TrackPoints(const std::vector<cv::Mat>& from, const std::vector<cv::Mat>& to,
                   const std::vector<cv::Point2f>& pts, const std::vector<cv::Point2f>* initial,
                   std::vector<cv::Point2f>* out, std::vector<uchar>* status, std::vector<float>* err) const;
  // Tracks pts starting at pts + offset, then applies the border, patch-error and forward-backward checks.
  // *out: tracked positions; *keep: 1 where every check passed.
  void TrackAndCheck(const std::vector<cv::Mat>& from_pyramid, const std::vector<cv::Mat>& to_pyramid,
                     const std::vector<cv::Point2f>& pts, const std::vector<cv::Point2f>& offset,
                     std::vector<cv::Point2f>* out, std::vector<uchar>* keep) const;
  // Aligns every track with keep[i] set to its anchor template in gray, starting at (*pts)[i] with the track's last
  // affine map; updates (*pts)[i] and the tracks' affine maps / anchors, clears keep[i] of the tracks that fail.
  // prev_pts / pyramid (this frame's LK pyramid): for base-level LK of tracks re-anchored at their LK position.
  void RefineToAnchors(const cv::Mat& gray, const std::vector<cv::Point2f>& prev_pts,
                       const std::vector<cv::Mat>& pyramid, std::vector<cv::Point2f>* pts, std::vector<uchar>* keep);
  void RemoveDuplicates(std::vector<LiveTrack>* tracks) const;
  void Detect(const cv::Mat& gray, std::vector<LiveTrack>* tracks);

  KltTrackerOptions options_;
  int quota_ = 1;
  int64_t next_id_ = 0;
  int frames_ = 0;                   // frames processed in total
  int frames_since_reset_ = 0;       // frames processed since the last reset
  cv::Point2f median_velocity_;      // px/frame, median displacement of the tracks continued into the last frame
  double response_reference_ = 0.0;  // strongest Shi-Tomasi response seen recently (see Detect)
  cv::Size size_;
  cv::Mat prev_gray_;
  std::vector<cv::Mat> prev_pyramid_;  // LK pyramid: float levels with a pad_ border (empty below finest_level_)
  int levels_ = 0;                     // levels above the base in prev_pyramid_ (and in the current pyramid)
  int finest_level_ = 0;               // level on which LK stops (lk_stop_level; 0 without anchor_refine)
  int pad_ = 0;                        // px, replicated border of every LK pyramid level
  std::vector<LiveTrack> tracks_;
  KltTrackStats stats_;
};

}  // namespace objscan
