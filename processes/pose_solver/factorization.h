// Tomasi–Kanade factorization (scaled-orthographic / weak-perspective camera) of a measurement matrix, and the
// automatic choice of the start span of the pose solver. LCM-free, deterministic, no threads.
//
// Model: for frame f and point p, pixel_fp ≈ s_f * P2 * R_f * X_p + t_f, where R_f is a rotation (camera_from_model,
// rows = camera x and y axes in the model frame), P2 keeps the first two rows, s_f > 0 the weak-perspective scale
// (≈ focal / depth) and t_f the image of the shape centroid. The solution is unique up to a global rotation (fixed
// here by R_0 = I), the shape scale (fixed by s_0 = 1, so the shape is in pixel units of frame 0) and the classic
// depth-reversal (Necker) ambiguity (R_f -> D R_f D, X -> D X with D = diag(1, 1, -1)); Mirrored() returns the other
// member of that pair. Affine -> metric upgrade from the orthonormality constraints m_f·m_f = n_f·n_f, m_f·n_f = 0.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace objscan {

struct FactorizationResult {
  std::vector<Eigen::Matrix3d> camera_from_model;  // per frame, rotation (R_0 = I)
  std::vector<double> scale;                       // per frame weak-perspective scale s_f (s_0 = 1)
  std::vector<Eigen::Vector2d> centroid_px;        // per frame t_f, px: image of the shape centroid
  Eigen::Matrix3Xd shape;                          // 3 x P, model frame, centred, in frame-0 pixel units
  double residual_rms_px = 0;                      // RMS of the rank-3 metric model over all measurements, px
  // The depth-reversed solution (same image residual).
  FactorizationResult Mirrored() const;
};

// measurements[f][p]: pixel (u, v) of point p in frame f; every point must be seen in every frame.
// Needs >= 3 frames and >= 4 points. Returns false (with *why) on too little data, a rank-deficient measurement
// matrix or a metric upgrade without a positive-definite solution (e.g. no rotation between the frames).
bool FactorizeWeakPerspective(const std::vector<std::vector<Eigen::Vector2d>>& measurements,
                              FactorizationResult* result, std::string* why = nullptr);

// Largest rotation angle (rad) of any frame against frame 0 in a factorization.
double MaxRotationAngle(const FactorizationResult& result);

struct StartSpanOptions {
  int min_common_tracks = 30;     // points tracked through every frame of the span
  int min_frames = 4;             // frames in the span (>= 3)
  int max_frames = 60;            // the span is not extended beyond this many frames
  double min_rotation_deg = 8.0;  // deg, parallax: rotation of the last vs the first frame (factorization)
};

// The span chooser over a sequence of frames given as id -> pixel lists: finds the first window [first, last]
// whose common tracks number >= min_common_tracks and whose factorized rotation reaches min_rotation_deg.
// frames[i] holds (track id, pixel) pairs sorted by id. Returns false when no window qualifies yet.
struct TrackList {
  std::vector<int64_t> ids;             // sorted ascending
  std::vector<Eigen::Vector2d> pixels;  // same order
};
// why (optional): on false, what was missing ("3 frames share >= 30 tracks (need 4)", "rotation 2.1 deg < 8 deg ...").
bool SelectStartSpan(const std::vector<TrackList>& frames, const StartSpanOptions& options, int* first, int* last,
                     std::vector<int64_t>* common_ids, std::string* why = nullptr);

// A start span's reconstructed camera motion against the odometry's (world_from_camera per frame of the span, in
// any two frames): the translations relative to the span's first camera, in that camera's frame, must agree up to
// one positive scale, to within half the odometry's travel plus 5 mm at every frame. Odometry is a poor metric but
// not a wrong direction; a short span can fit its pixels in the depth-reversed or a depth-ambiguous solution
// (room_07: a 52 mm sideways retrace reconstructed as 60 mm of descent at 0.16 px RMS, and every pose after it was
// off). Spans whose odometry travelled under 20 mm are not judged (true). False with *why (optional) saying by how
// much they disagree. Needs visual.size() == odometry.size().
bool SpanMotionAgreesWithOdometry(const std::vector<Eigen::Isometry3d>& visual_world_from_camera,
                                  const std::vector<Eigen::Isometry3d>& odometry_world_from_camera,
                                  std::string* why = nullptr);

// Ids present in every frame of [first, last] (sorted).
std::vector<int64_t> CommonIds(const std::vector<TrackList>& frames, int first, int last);

}  // namespace objscan
