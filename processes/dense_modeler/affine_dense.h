// Dense correspondences between two posed views by affine invariance (LCM-free).
// Given feature points tracked in both views A and B (pixel pairs), the points of A are Delaunay-triangulated;
// every pixel P of A inside a triangle gets barycentric coordinates (α, β, γ) and is mapped to the presumed
// correspondence Q = α·b0 + β·b1 + γ·b2 in B (mapping kAffine), or through the plane of the triangle's three
// triangulated vertices (mapping kPlane: perspective-correct, exact for planar triangles). Q is kept only when it
// lies within epipolar_threshold_px of the epipolar line of P and its radiance matches P (mean |ΔBGR| and an NCC
// over a small window warped by the triangle's affine map); optionally Q is refined by a 1-D NCC search along the
// epipolar line first. P–Q is then triangulated (ray midpoint) into a world point. With a region of interest
// (region_of_interest.h) only pixels inside the region's projected box are visited, triangles whose triangulated
// vertices are surely outside it are skipped and points outside it are rejected.
// Frames/units: poses world_from_camera in mm, pixels (u, v) = (column, row) with the origin at the centre of the
// top-left pixel. Lens distortion is honoured for rays and the epipolar test (PinholeCamera::Unproject); the
// 1-D refinement searches along the undistorted-model epipolar direction. Never throws for bad data: degenerate
// input (fewer than 3 matches, invalid camera, coincident centres) gives an empty result.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "common/camera_model.h"
#include "processes/dense_modeler/region_of_interest.h"

namespace objscan {

// One posed image.
struct DenseView {
  int64_t seq = 0;                                                      // frame sequence number
  int64_t utime = 0;                                                    // µs, capture time
  PinholeCamera camera;                                                 // intrinsics matching image
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();  // mm
  cv::Mat image;                                                        // CV_8UC3 (BGR) or CV_8UC1
  cv::Mat gray;   // optional CV_32FC1 gray of image, its size (else made from gray8 or image per call)
  cv::Mat gray8;  // optional CV_8UC1 gray of image, its size (else converted from image per call where needed)
};

// The same feature seen in both views (px).
struct PointMatch {
  Eigen::Vector2d a;  // px in view A
  Eigen::Vector2d b;  // px in view B
};

// A reconstructed surface point with the colour of its pixel in A.
struct DensePoint {
  Eigen::Vector3d point_in_world;  // mm
  std::array<uint8_t, 3> bgr{{0, 0, 0}};
  Eigen::Vector2f pixel_a = Eigen::Vector2f::Zero();        // px, P in A
  Eigen::Vector2f pixel_b = Eigen::Vector2f::Zero();        // px, the accepted (possibly refined) Q in B
  Eigen::Vector3f toward_camera = Eigen::Vector3f::Zero();  // unit, world, from the point towards the pair's
                                                            // cameras (midpoint of the two centres); zero = unknown
};

enum class DenseMapping : int { kAffine = 0, kPlane = 1 };

struct AffineDenseOptions {
  int mapping = 0;                        // 0 = affine barycentric map, 1 = plane of the triangle (perspective-correct)
  int pixel_step = 1;                     // px, sample every pixel_step-th row and column of A (>= 1)
  double epipolar_threshold_px = 1.0;     // px, max distance of Q to the epipolar line of P (> 0)
  double max_color_difference = 30.0;     // gray levels, max mean |ΔB|,|ΔG|,|ΔR| between P and Q (< 0 = off)
  int ncc_half_window = 2;                // px, half side of the NCC window (0 = no NCC check)
  double min_ncc = 0.7;                   // min NCC of the warped window, [-1, 1]
  double min_window_stddev = 0.5;         // gray levels, windows flatter than this skip the NCC test (textureless)
  bool refine_along_epipolar = true;      // refine Q by a 1-D NCC search along the epipolar line
  double refine_search_px = 3.0;          // px, half length of the refinement search (> 0); the affine map of a
                                          // curved surface's triangle is off by more than 1.5 px often enough that
                                          // +-1.5 px lost much of the lower sphere and the box (docs/benchmarks.md)
  double refine_step_px = 0.5;            // px, refinement search step (> 0); the best step is refined by a
                                          // parabola through its neighbours
  int refine_first_steps = 3;             // steps each side of the prediction scored first, the rest only when
                                          // their best is at their edge or under refine_first_min_ncc (0 or >= the
                                          // search's steps: every step at once; docs/benchmarks.md, 3 Dec)
  double refine_first_min_ncc = 0.95;     // NCC the first steps' best needs to end the search there, [-1, 1]
  bool reject_refine_at_border = true;    // drop P when the refinement's best NCC is at either end of the search:
                                          // the true match lies farther than refine_search_px from the affine
                                          // prediction (a triangle across a crease or a depth change)
  int refine_kernel = 0;                  // implementation of the window NCCs, all bit-identical (for tests and
                                          // benchmarks): 0 = AVX2 where the CPU has it, else 1; 1 = the reference
                                          // (one window NCC per search step, SSE2 sampling); 2 = portable scalar
                                          // sampling, the search's steps batched; 3 = AVX2, steps batched (1 without
                                          // AVX2)
  double min_triangle_area_px2 = 4.0;     // px², smaller triangles are skipped
  double max_triangle_edge_px = 80.0;     // px, triangles with a longer edge in A or B are skipped
  double strict_triangle_edge_px = 50.0;  // px, triangles with a longer edge in A or B get the floor junction's
                                          // photometric checks (junction_min_window_stddev, junction_min_ncc): far
                                          // from the vertices the affine map follows the chord of a curved surface
                                          // (a 50 mm chord of the 100 mm sphere lies 3.1 mm inside), and only a
                                          // textured window lets the refinement pull Q onto the surface; the sim
                                          // sphere's 3.5-4.6 mm dents came from such pixels (>= max_triangle_edge_px
                                          // = off), > 0
  double min_triangle_angle_deg = 10.0;   // deg, thinner triangles (smallest angle in A) are skipped
  double max_vertex_depth_ratio = 1.15;   // max/min vertex depth in A; larger = depth edge, skipped (>= 1)
  double max_triangle_slant_deg = 80.0;   // deg, max angle between the 3-D triangle's normal and the view ray of
                                          // its centroid in A; more oblique = likely spans a depth edge, skipped
  double min_triangulation_angle_deg = 1.0;           // deg, rays meeting at a smaller angle are rejected
  double max_reprojection_px = 1.0;                   // px, max reprojection error of the triangulated point in A or B
  double min_feature_separation_px = 0.5;             // px, features closer than this to an earlier one are dropped
  bool use_world_box = false;                         // keep only points inside [box_min, box_max] (world, mm)
  Eigen::Vector3d box_min = Eigen::Vector3d::Zero();  // mm, world
  Eigen::Vector3d box_max = Eigen::Vector3d::Zero();  // mm, world
  cv::Rect roi_a;           // px, only pixels of A inside this rectangle (empty = whole image)
  RegionOfInterest region;  // world region the points must lie in (invalid = everywhere); pixels of A
                            // outside its projected box and triangles surely outside it are skipped
  // Triangles joining a floor vertex to one above the floor clearance (region with a floor only) cover the
  // object's shadowed lower part but also the air of the crevice, where flat dark windows pass any NCC test:
  double junction_min_window_stddev = 4.0;  // gray levels, their pixels need windows this textured (< 0 = off)
  double junction_min_ncc = 0.9;            // and this NCC, [-1, 1]
  // and must not be explained by the floor as well: P's ray meets the floor plane at a point seen in B at q_f; P is
  // dropped when q_f is closer than junction_floor_min_separation_px to Q or its NCC is at least the NCC at Q
  // minus junction_floor_ncc_margin (the crevice's shadowed floor seen under the object, which the triangle's
  // plane would put in the air):
  double junction_floor_ncc_margin = 0.1;         // NCC units, <= 2 (< 0 = off)
  double junction_floor_min_separation_px = 1.0;  // px, >= 0
  // Triangles with every vertex on the floor (RegionOfInterest::TriangleOnFloor) are skipped: almost all their
  // points fall under the clearance (half of a sim pair's pixels went that way), the rest are floor mismatches.
  bool skip_floor_triangles = true;
  double region_slack_mm = 10.0;        // mm, a triangle is skipped only when its vertices are this far outside
  double region_image_margin_px = 8.0;  // px, margin around the region's projected box in A
};

// Counters of one pair (for status, tests and tuning).
struct DensePairStats {
  int features = 0;                 // matches used after deduplication
  int triangles = 0;                // Delaunay triangles
  int triangles_skipped_shape = 0;  // too small, too large or too thin
  int triangles_skipped_depth = 0;  // depth ratio or slant over the limit, floor junction, or a vertex failed to
                                    // triangulate
  int64_t pixels = 0;               // pixels of A inside used triangles (and the ROI)
  int64_t rejected_outside = 0;     // Q outside B
  int64_t rejected_epipolar = 0;
  int64_t rejected_color = 0;
  int64_t rejected_ncc = 0;
  int64_t rejected_refine_border = 0;    // refinement's best score at the end of its search
  int64_t refine_searches = 0;           // pixels whose Q was searched along the epipolar line
  int64_t refine_full_searches = 0;      // of those, every step scored (all at once, or the first steps' best
                                         // at their edge or under refine_first_min_ncc)
  int64_t rejected_triangulation = 0;    // small angle, behind a camera or reprojection error
  int64_t rejected_box = 0;              // outside the world box or the region
  int64_t rejected_floor_ambiguous = 0;  // floor-junction pixel that the floor plane explains as well
  int triangles_skipped_region = 0;      // vertices surely outside the region, or all on the floor
  int64_t accepted = 0;
  double mean_refine_shift_px = 0;  // mean |Q_refined - Q| (refinement on)
};

// True when usable; otherwise false with *why set.
bool ValidateAffineDenseOptions(const AffineDenseOptions& options, std::string* why);

// True when the two views can form a pair: both images non-empty, of the same type and of their cameras' sizes,
// both cameras valid, the centres apart (> 1e-9 mm), and each given gray / gray8 of its image's size and type.
bool DensePairViewsUsable(const DenseView& a, const DenseView& b);

// The pixels of A a dense pair visits: options.roi_a (empty = the whole image) clipped to the image and, with a
// valid region, to the region's projected box (region_image_margin_px around it). Empty: nothing to visit.
cv::Rect DensePairRoi(const PinholeCamera& camera_a, const Eigen::Isometry3d& world_from_a,
                      const AffineDenseOptions& options);

// Dense points for the pair (A, B). a.image and b.image must have the same type (gray or BGR) and match their
// cameras' sizes (else the result is empty). Output order is deterministic (triangle by triangle, raster inside).
// Keeps per-thread scratch buffers between calls (gray images, visited mask, search buffers).
std::vector<DensePoint> ComputeDensePair(const DenseView& a, const DenseView& b, const std::vector<PointMatch>& matches,
                                         const AffineDenseOptions& options, DensePairStats* stats = nullptr);
// The same into *out (cleared first; its capacity is reused, so a caller that keeps one buffer from pair to pair
// saves the allocation and first-touch page faults of ~1.4 MB per pair: ~10 % of a pair's time, docs/benchmarks.md).
void ComputeDensePair(const DenseView& a, const DenseView& b, const std::vector<PointMatch>& matches,
                      const AffineDenseOptions& options, std::vector<DensePoint>* out, DensePairStats* stats = nullptr);

// The pixel pair of a dense point, kept to triangulate it again later (20 bytes instead of DensePoint's 56).
struct DenseMatch {
  Eigen::Vector2f pixel_a = Eigen::Vector2f::Zero();  // px, P in A
  Eigen::Vector2f pixel_b = Eigen::Vector2f::Zero();  // px, Q in B
  std::array<uint8_t, 3> bgr{{0, 0, 0}};              // colour of P
};

// The pixel pairs and colours of dense points, in their order.
std::vector<DenseMatch> DenseMatchesOf(const std::vector<DensePoint>& points);

// The dense points of matches (ComputeDensePair's pixel pairs) triangulated with other poses of the same two views,
// e.g. the pose solver's final poses: ComputeDensePair's geometric checks with the new poses (Q within
// epipolar_threshold_px of P's epipolar line, triangulation angle, reprojection error in A and B, world box, region;
// the radiance checks belong to the images and are not redone). Output in input order; *rejected (optional) gets the
// number dropped. Empty for coincident centres or invalid cameras. Never throws.
std::vector<DensePoint> TriangulateDenseMatches(const PinholeCamera& camera_a, const Eigen::Isometry3d& world_from_a,
                                                const PinholeCamera& camera_b, const Eigen::Isometry3d& world_from_b,
                                                const std::vector<DenseMatch>& matches,
                                                const AffineDenseOptions& options, int64_t* rejected = nullptr);

// Essential matrix E with nb^T E na = 0 for normalized coordinates (x/z, y/z, 1) of the same point in A and B.
Eigen::Matrix3d EssentialMatrix(const Eigen::Isometry3d& world_from_a, const Eigen::Isometry3d& world_from_b);

// Distance (px of B, using fx of B) of pixel q of B from the epipolar line of pixel p of A.
double EpipolarDistancePx(const Eigen::Matrix3d& essential, const PinholeCamera& camera_a,
                          const PinholeCamera& camera_b, const Eigen::Vector2d& p, const Eigen::Vector2d& q);

// Midpoint of the shortest segment between two rays (origin, unit direction). False when (nearly) parallel or when
// the point lies behind either origin. *angle_rad (optional) gets the angle between the rays.
bool TriangulateMidpoint(const Eigen::Vector3d& origin_a, const Eigen::Vector3d& dir_a, const Eigen::Vector3d& origin_b,
                         const Eigen::Vector3d& dir_b, Eigen::Vector3d* point, double* angle_rad = nullptr);

// NCC between the window of gray image A (CV_32FC1) around p (offsets d in [-h, h]², h = half_window in [0, 10])
// and gray image B at q + J·d (bilinear). Returns -2 when a window leaves an image (or h is out of range).
// *stddev_a/*stddev_b (optional) get the window std-devs. Samples B with SIMD where available (AVX2, else SSE2).
double WarpedNcc(const cv::Mat& gray_a, const Eigen::Vector2d& p, const cv::Mat& gray_b, const Eigen::Vector2d& q,
                 const Eigen::Matrix2d& jacobian, int half_window, double* stddev_a = nullptr,
                 double* stddev_b = nullptr);
// The same with the portable (scalar) sampling path; bit-identical to WarpedNcc (for tests).
double WarpedNccPortable(const cv::Mat& gray_a, const Eigen::Vector2d& p, const cv::Mat& gray_b,
                         const Eigen::Vector2d& q, const Eigen::Matrix2d& jacobian, int half_window,
                         double* stddev_a = nullptr, double* stddev_b = nullptr);

// CV_32FC1 gray of a CV_8UC1 / CV_8UC3 (BGR) image.
cv::Mat GrayFloat(const cv::Mat& image);

// CV_8UC1 gray of a CV_8UC1 (the same data, not copied) / CV_8UC3 (BGR) image; GrayFloat is this converted to float.
cv::Mat Gray8(const cv::Mat& image);

}  // namespace objscan
