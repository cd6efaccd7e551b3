#include "processes/dense_modeler/pair_matches.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

namespace objscan {
namespace {

cv::Mat Gray8(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat gray;
  cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  return gray;
}

}  // namespace

bool ValidatePairMatchOptions(const PairMatchOptions& o, std::string* why) {
  std::ostringstream e;
  if (o.max_corners < 1) e << "pair-match max-corners must be >= 1; ";
  if (!(o.corner_quality > 0 && o.corner_quality < 1)) e << "pair-match corner-quality must be in (0, 1); ";
  if (!(o.min_distance_px > 0)) e << "pair-match min-distance must be > 0; ";
  if (!(o.min_track_distance_px > 0)) e << "pair-match min-track-distance must be > 0; ";
  if (o.window_px < 5 || o.window_px % 2 == 0) e << "pair-match window must be odd and >= 5; ";
  if (o.pyramid_levels < 0 || o.pyramid_levels > 6) e << "pair-match pyramid-levels must be in [0, 6]; ";
  if (!(o.max_backward_error_px > 0)) e << "pair-match max-backward-error must be > 0; ";
  if (!(o.max_residual > 0)) e << "pair-match max-residual must be > 0; ";
  if (!(o.bare_distance_px > 0)) e << "pair-match bare-distance must be > 0; ";
  if (!(o.bare_max_backward_error_px > 0)) e << "pair-match bare-max-backward-error must be > 0; ";
  if (!(o.max_epipolar_px > 0)) e << "pair-match max-epipolar must be > 0; ";
  if (o.guess_neighbours < 0) e << "pair-match guess-neighbours must be >= 0; ";
  if (why) *why = e.str();
  return e.str().empty();
}

std::vector<PointMatch> AddPairMatches(const DenseView& a, const DenseView& b, const std::vector<PointMatch>& tracked,
                                       const cv::Rect& rect_in, const PairMatchOptions& o, PairMatchStats* stats_out) {
  PairMatchStats stats;
  std::vector<PointMatch> out;
  auto finish = [&]() {
    if (stats_out) *stats_out = stats;
    return out;
  };
  if (!ValidatePairMatchOptions(o, nullptr) || a.image.empty() || b.image.empty() || a.image.type() != b.image.type() ||
      a.image.size() != b.image.size() || !a.camera.IsValid() || !b.camera.IsValid() ||
      a.image.cols != a.camera.width || a.image.rows != a.camera.height ||
      (a.world_from_camera.translation() - b.world_from_camera.translation()).norm() < 1e-9)
    return finish();
  const cv::Rect image_rect(0, 0, a.image.cols, a.image.rows);
  const cv::Rect rect = rect_in.area() > 0 ? (rect_in & image_rect) : image_rect;
  if (rect.width < o.window_px || rect.height < o.window_px) return finish();

  // Corners of A in the rectangle, away from the tracked features.
  const cv::Mat gray_a = Gray8(a.image), gray_b = Gray8(b.image);
  cv::Mat1b mask(a.image.rows, a.image.cols, uchar(0));
  mask(rect).setTo(255);
  std::vector<cv::Point2f> tracked_a;
  tracked_a.reserve(tracked.size());
  for (const PointMatch& m : tracked) {
    if (!m.a.allFinite() || !m.b.allFinite()) continue;
    tracked_a.emplace_back(static_cast<float>(m.a.x()), static_cast<float>(m.a.y()));
    cv::circle(mask, cv::Point(cvRound(m.a.x()), cvRound(m.a.y())), cvRound(o.min_track_distance_px), cv::Scalar(0),
               -1);
  }
  std::vector<cv::Point2f> corners;
  cv::goodFeaturesToTrack(gray_a, corners, o.max_corners, o.corner_quality, o.min_distance_px, mask);
  stats.corners = static_cast<int>(corners.size());
  if (corners.empty()) return finish();

  // Start LK where the corner's ray meets the median distance (along A's rays) of the nearest tracked features,
  // seen in B: the views are a pair gap apart (tens of pixels of parallax, varying across the object), and a
  // periodic texture would lock LK onto the wrong period from a poor start.
  const Eigen::Vector3d center_a = a.world_from_camera.translation(), center_b = b.world_from_camera.translation();
  const Eigen::Matrix3d rwa = a.world_from_camera.linear(), rwb = b.world_from_camera.linear();
  const Eigen::Isometry3d b_from_world = b.world_from_camera.inverse();
  auto ray_a = [&](const Eigen::Vector2d& p) { return (rwa * a.camera.Unproject(p).homogeneous()).normalized(); };
  std::vector<Eigen::Vector2d> known_a;  // tracked features that triangulate, with their distance from A's centre
  std::vector<double> known_range;       // mm
  for (const PointMatch& m : tracked) {
    if (!m.a.allFinite() || !m.b.allFinite()) continue;
    Eigen::Vector3d x;
    const Eigen::Vector3d db = (rwb * b.camera.Unproject(m.b).homogeneous()).normalized();
    if (!TriangulateMidpoint(center_a, ray_a(m.a), center_b, db, &x)) continue;
    known_a.push_back(m.a);
    known_range.push_back((x - center_a).norm());
  }
  std::vector<cv::Point2f> guess = corners;
  std::vector<double> track_distance(corners.size(), std::numeric_limits<double>::infinity());  // px
  std::vector<std::pair<double, size_t>> near;
  std::vector<double> ranges;
  for (size_t c = 0; c < corners.size(); ++c) {
    const Eigen::Vector2d pc(corners[c].x, corners[c].y);
    for (const PointMatch& m : tracked)
      if (m.a.allFinite() && m.b.allFinite()) track_distance[c] = std::min(track_distance[c], (m.a - pc).norm());
    if (o.guess_neighbours == 0 || known_a.empty()) continue;
    near.clear();
    for (size_t i = 0; i < known_a.size(); ++i) near.emplace_back((known_a[i] - pc).squaredNorm(), i);
    const size_t k = std::min<size_t>(o.guess_neighbours, near.size());
    std::partial_sort(near.begin(), near.begin() + k, near.end());
    ranges.clear();
    for (size_t j = 0; j < k; ++j) ranges.push_back(known_range[near[j].second]);
    std::nth_element(ranges.begin(), ranges.begin() + k / 2, ranges.end());
    Eigen::Vector2d qb;
    if (b.camera.Project(b_from_world * (center_a + ranges[k / 2] * ray_a(pc)), &qb) && b.camera.InImage(qb))
      guess[c] = cv::Point2f(static_cast<float>(qb.x()), static_cast<float>(qb.y()));
  }
  const cv::Size window(o.window_px, o.window_px);
  const cv::TermCriteria term(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
  std::vector<uchar> status_ab, status_ba;
  std::vector<float> err_ab, err_ba;
  std::vector<cv::Point2f> in_b = guess;
  cv::calcOpticalFlowPyrLK(gray_a, gray_b, corners, in_b, status_ab, err_ab, window, o.pyramid_levels, term,
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  std::vector<cv::Point2f> back = corners;
  cv::calcOpticalFlowPyrLK(gray_b, gray_a, in_b, back, status_ba, err_ba, window, o.pyramid_levels, term,
                           cv::OPTFLOW_USE_INITIAL_FLOW);

  const Eigen::Matrix3d essential = EssentialMatrix(a.world_from_camera, b.world_from_camera);
  for (size_t c = 0; c < corners.size(); ++c) {
    const Eigen::Vector2d pa(corners[c].x, corners[c].y), pb(in_b[c].x, in_b[c].y);
    if (!status_ab[c] || !status_ba[c] || !pb.allFinite() || !b.camera.InImage(pb)) {
      ++stats.lost;
      continue;
    }
    const bool bare = track_distance[c] >= o.bare_distance_px;
    if (std::hypot(back[c].x - corners[c].x, back[c].y - corners[c].y) >
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
