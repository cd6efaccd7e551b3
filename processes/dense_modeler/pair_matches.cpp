#include "processes/dense_modeler/pair_matches.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "common/geometry.h"
#include "processes/dense_modeler/image_point_grid.h"

namespace objscan {
namespace {

constexpr double kMaxDistancePx = 1000.0;              // px, ValidatePairMatchOptions' limit of the distance options
constexpr double kMinRangeAngleRad = 1.0 * kDegToRad;  // tracked features meeting at less give no range
constexpr double kGridCellPx = 16.0;                   // px, cells of the nearest-feature grids

}  // namespace

bool ValidatePairMatchOptions(const PairMatchOptions& o, std::string* why) {
  std::ostringstream e;
  if (o.max_corners < 1) e << "pair-match max_corners must be >= 1; ";
  if (!(o.corner_quality > 0 && o.corner_quality < 1)) e << "pair-match corner_quality must be in (0, 1); ";
  if (!(o.min_distance_px > 0)) e << "pair-match min_distance_px must be > 0; ";
  if (!(o.min_track_distance_px > 0)) e << "pair-match min_track_distance_px must be > 0; ";
  if (o.window_px < 5 || o.window_px % 2 == 0) e << "pair-match window must be odd and >= 5; ";
  if (o.pyramid_levels < 0 || o.pyramid_levels > 6) e << "pair-match pyramid_levels must be in [0, 6]; ";
  if (o.lk_max_iterations < 1 || o.lk_max_iterations > 100) e << "pair-match lk_max_iterations must be in [1, 100]; ";
  if (!(o.lk_epsilon_px > 0 && o.lk_epsilon_px < 1)) e << "pair-match lk_epsilon_px must be in (0, 1) px; ";
  if (!(o.max_backward_error_px > 0)) e << "pair-match max_backward_error_px must be > 0; ";
  if (!(o.max_residual > 0)) e << "pair-match max_residual must be > 0; ";
  if (!(o.bare_distance_px > 0)) e << "pair-match bare_distance_px must be > 0; ";
  if (!(o.bare_max_backward_error_px > 0)) e << "pair-match bare_max_backward_error_px must be > 0; ";
  if (!(o.max_epipolar_px > 0)) e << "pair-match max_epipolar_px must be > 0; ";
  if (o.guess_neighbours < 0) e << "pair-match guess_neighbours must be >= 0; ";
  if (!(o.min_distance_px <= kMaxDistancePx) || !(o.min_track_distance_px <= kMaxDistancePx) ||
      !(o.bare_distance_px <= kMaxDistancePx))
    e << "pair-match distances must be <= " << kMaxDistancePx << " px; ";
  if (!(o.bare_distance_px >= o.min_track_distance_px))
    e << "pair-match bare_distance_px must be >= min_track_distance_px (else every corner is bare); ";
  if (!(o.bare_max_backward_error_px >= o.max_backward_error_px))
    e << "pair-match bare_max_backward_error_px must be >= max_backward_error_px (the bare rule is the looser one); ";
  if (why) *why = e.str();
  return e.str().empty();
}

std::vector<PointMatch> AddPairMatches(const DenseView& a, const DenseView& b, const std::vector<PointMatch>& tracked,
                                       const cv::Rect& rect_in, const RegionOfInterest& region,
                                       const PairMatchOptions& o, PairMatchStats* stats_out) {
  PairMatchStats stats;
  std::vector<PointMatch> out;
  auto finish = [&]() {
    if (stats_out) *stats_out = stats;
    return out;
  };
  const int type = a.image.type();
  if (!ValidatePairMatchOptions(o, nullptr) || !a.world_from_camera.matrix().allFinite() ||
      !b.world_from_camera.matrix().allFinite() || !DensePairViewsUsable(a, b) || (type != CV_8UC1 && type != CV_8UC3))
    return finish();
  const cv::Rect image_rect(0, 0, a.image.cols, a.image.rows);
  const cv::Rect rect = rect_in.area() > 0 ? (rect_in & image_rect) : image_rect;
  if (rect.width < o.window_px || rect.height < o.window_px) return finish();
  std::vector<PointMatch> known;  // the finite tracked matches
  known.reserve(tracked.size());
  for (const PointMatch& m : tracked)
    if (m.a.allFinite() && m.b.allFinite()) known.push_back(m);
  std::vector<Eigen::Vector2d> known_a;  // their positions in A, in a grid for the nearest-feature distance
  known_a.reserve(known.size());
  ImagePointGrid known_grid(a.image.cols, a.image.rows, kGridCellPx);
  for (const PointMatch& m : known) {
    known_grid.Insert(m.a, static_cast<int>(known_a.size()));
    known_a.push_back(m.a);
  }

  // Corners of A in the rectangle, away from the tracked features (detected in the rectangle only).
  const cv::Mat gray_a = a.gray8.empty() ? Gray8(a.image) : a.gray8;
  const cv::Mat gray_b = b.gray8.empty() ? Gray8(b.image) : b.gray8;
  cv::Mat1b mask(rect.size(), uchar(255));
  for (const PointMatch& m : known)
    cv::circle(mask, cv::Point(cvRound(m.a.x()) - rect.x, cvRound(m.a.y()) - rect.y), cvRound(o.min_track_distance_px),
               cv::Scalar(0), -1);
  std::vector<cv::Point2f> corners;
  cv::goodFeaturesToTrack(gray_a(rect), corners, o.max_corners, o.corner_quality, o.min_distance_px, mask);
  for (cv::Point2f& c : corners) c += cv::Point2f(static_cast<float>(rect.x), static_cast<float>(rect.y));
  stats.corners = static_cast<int>(corners.size());
  if (corners.empty()) return finish();

  // Start LK where the corner's ray meets the median distance (along A's rays) of the nearest tracked features,
  // seen in B: the views are a pair gap apart (tens of pixels of parallax, varying across the object), and a
  // periodic texture would lock LK onto the wrong period from a poor start.
  const Eigen::Vector3d center_a = a.world_from_camera.translation(), center_b = b.world_from_camera.translation();
  const Eigen::Matrix3d rwa = a.world_from_camera.linear(), rwb = b.world_from_camera.linear();
  const Eigen::Isometry3d b_from_world = b.world_from_camera.inverse();
  const bool floor_test = o.skip_floor_corners && region.valid && region.has_floor && region.floor_clearance_mm > 0;
  auto ray_a = [&](const Eigen::Vector2d& p) { return (rwa * a.camera.Unproject(p).homogeneous()).normalized(); };
  std::vector<Eigen::Vector2d> ranged_a;  // tracked features that triangulate (rays >= 1 deg apart)
  std::vector<double> range;              // mm, their distance from A's centre
  std::vector<char> on_floor;             // less than half the floor clearance above the region's floor
  for (const PointMatch& m : known) {
    Eigen::Vector3d x;
    double angle = 0;
    const Eigen::Vector3d db = (rwb * b.camera.Unproject(m.b).homogeneous()).normalized();
    if (!TriangulateMidpoint(center_a, ray_a(m.a), center_b, db, &x, &angle) || angle < kMinRangeAngleRad) continue;
    ranged_a.push_back(m.a);
    range.push_back((x - center_a).norm());
    on_floor.push_back(floor_test && region.HeightAboveFloor(x) < 0.5 * region.floor_clearance_mm);
  }
  ImagePointGrid ranged_grid(a.image.cols, a.image.rows, kGridCellPx);
  for (size_t i = 0; i < ranged_a.size(); ++i) ranged_grid.Insert(ranged_a[i], static_cast<int>(i));
  // The corners to follow (not among floor tracks), their LK starts and distances to the nearest tracked feature.
  std::vector<cv::Point2f> from_a, guess;
  std::vector<double> track_distance;  // px
  std::vector<std::pair<double, size_t>> near;
  std::vector<double> ranges;
  for (const cv::Point2f& corner : corners) {
    const Eigen::Vector2d pc(corner.x, corner.y);
    const double nearest = known_grid.NearestDistance(known_a, pc);
    cv::Point2f start = corner;
    if (o.guess_neighbours > 0 && !ranged_a.empty()) {
      ranged_grid.NearestK(ranged_a, pc, static_cast<size_t>(o.guess_neighbours), &near);
      const size_t k = near.size();
      ranges.clear();
      bool floor = floor_test;
      for (size_t j = 0; j < k; ++j) {
        ranges.push_back(range[near[j].second]);
        floor = floor && on_floor[near[j].second];
      }
      if (floor) {  // its nearest tracked features all lie on the floor: the dense pair skips floor triangles
        ++stats.skipped_floor;
        continue;
      }
      std::nth_element(ranges.begin(), ranges.begin() + k / 2, ranges.end());
      Eigen::Vector2d qb;
      if (b.camera.Project(b_from_world * (center_a + ranges[k / 2] * ray_a(pc)), &qb) && b.camera.InImage(qb))
        start = cv::Point2f(static_cast<float>(qb.x()), static_cast<float>(qb.y()));
    }
    from_a.push_back(corner);
    guess.push_back(start);
    track_distance.push_back(nearest);
  }
  if (from_a.empty()) return finish();
  const cv::Size window(o.window_px, o.window_px);
  const cv::TermCriteria term(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, o.lk_max_iterations, o.lk_epsilon_px);
  std::vector<uchar> status_ab, status_ba;
  std::vector<float> err_ab, err_ba;
  std::vector<cv::Mat> pyramid_a, pyramid_b;  // built once for both directions
  const int levels = std::min(cv::buildOpticalFlowPyramid(gray_a, pyramid_a, window, o.pyramid_levels),
                              cv::buildOpticalFlowPyramid(gray_b, pyramid_b, window, o.pyramid_levels));
  std::vector<cv::Point2f> in_b = guess;
  cv::calcOpticalFlowPyrLK(pyramid_a, pyramid_b, from_a, in_b, status_ab, err_ab, window, levels, term,
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  // Back from B, started as far from the corner as the forward pass moved from its start: a forward pass that
  // locked onto the wrong period of a texture then starts a period off and shows it, where a start at the corner
  // itself would stay there.
  std::vector<cv::Point2f> back(from_a.size());
  for (size_t c = 0; c < from_a.size(); ++c) back[c] = from_a[c] + (in_b[c] - guess[c]);
  cv::calcOpticalFlowPyrLK(pyramid_b, pyramid_a, in_b, back, status_ba, err_ba, window, levels, term,
                           cv::OPTFLOW_USE_INITIAL_FLOW);

  const Eigen::Matrix3d essential = EssentialMatrix(a.world_from_camera, b.world_from_camera);
  for (size_t c = 0; c < from_a.size(); ++c) {
    const Eigen::Vector2d pa(from_a[c].x, from_a[c].y), pb(in_b[c].x, in_b[c].y);
    if (!status_ab[c] || !status_ba[c] || !pb.allFinite() || !b.camera.InImage(pb)) {
      ++stats.lost;
      continue;
    }
    const bool bare = track_distance[c] >= o.bare_distance_px;
    if (std::hypot(back[c].x - from_a[c].x, back[c].y - from_a[c].y) >
        (bare ? o.bare_max_backward_error_px : o.max_backward_error_px)) {
      ++stats.rejected_backward;
      continue;
    }
    if (!bare && !(err_ab[c] <= o.max_residual)) {
      ++stats.rejected_residual;
      continue;
    }
    if (!(EpipolarDistancePx(essential, a.camera, b.camera, pa, pb) <= o.max_epipolar_px)) {
      ++stats.rejected_epipolar;
      continue;
    }
    out.push_back({pa, pb});
  }
  stats.added = static_cast<int>(out.size());
  return finish();
}

}  // namespace objscan
