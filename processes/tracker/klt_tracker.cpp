#include "processes/tracker/klt_tracker.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

namespace objscan {
namespace {

// Buckets of side `cell` px for "is there a point within radius" queries (radius <= cell).
class PointBuckets {
 public:
  PointBuckets(cv::Size size, double cell) : cell_(std::max(cell, 1.0)) {
    cols_ = std::max(1, static_cast<int>(std::ceil(size.width / cell_)) + 1);
    rows_ = std::max(1, static_cast<int>(std::ceil(size.height / cell_)) + 1);
    buckets_.resize(static_cast<size_t>(cols_) * static_cast<size_t>(rows_));
  }
  bool AnyWithin(const cv::Point2f& p, double radius) const {
    const int bx = Col(p.x), by = Row(p.y);
    const double r2 = radius * radius;
    for (int y = std::max(0, by - 1); y <= std::min(rows_ - 1, by + 1); ++y) {
      for (int x = std::max(0, bx - 1); x <= std::min(cols_ - 1, bx + 1); ++x) {
        for (const cv::Point2f& q : buckets_[static_cast<size_t>(y * cols_ + x)]) {
          const double dx = q.x - p.x, dy = q.y - p.y;
          if (dx * dx + dy * dy < r2) return true;
        }
      }
    }
    return false;
  }
  void Insert(const cv::Point2f& p) { buckets_[static_cast<size_t>(Row(p.y) * cols_ + Col(p.x))].push_back(p); }

 private:
  int Col(float x) const { return std::clamp(static_cast<int>(std::floor(x / cell_)), 0, cols_ - 1); }
  int Row(float y) const { return std::clamp(static_cast<int>(std::floor(y / cell_)), 0, rows_ - 1); }
  double cell_;
  int cols_ = 1, rows_ = 1;
  std::vector<std::vector<cv::Point2f>> buckets_;
};

// Per detection, the response reference keeps this fraction of its previous value (if no stronger corner is seen).
constexpr double kResponseReferenceDecay = 0.9;

struct Candidate {
  float response;
  int x, y;
};

}  // namespace

bool ValidateKltTrackerOptions(const KltTrackerOptions& o, std::string* why) {
  std::ostringstream e;
  if (o.max_tracks < 1) e << "max_tracks must be >= 1 (is " << o.max_tracks << "); ";
  if (o.grid_cols < 1 || o.grid_rows < 1) e << "grid_cols and grid_rows must be >= 1; ";
  if (o.max_per_cell < 0) e << "max_per_cell must be >= 0 (0 = automatic); ";
  if (o.border_margin_px < 0) e << "border_margin_px must be >= 0; ";
  if (!(o.min_distance_px >= 0.0) || !std::isfinite(o.min_distance_px)) e << "min_distance_px must be >= 0; ";
  if (!(o.duplicate_distance_px >= 0.0) || !std::isfinite(o.duplicate_distance_px))
    e << "duplicate_distance_px must be >= 0; ";
  if (!(o.quality_level > 0.0 && o.quality_level < 1.0)) e << "quality_level must be in (0, 1); ";
  if (!(o.min_eigenvalue >= 0.0) || !std::isfinite(o.min_eigenvalue)) e << "min_eigenvalue must be >= 0; ";
  if (o.corner_block_size < 3 || o.corner_block_size % 2 == 0 || o.corner_block_size > 31)
    e << "corner_block_size must be odd in [3, 31]; ";
  if (o.subpix_half_window < 0 || o.subpix_half_window > 15) e << "subpix_half_window must be in [0, 15]; ";
  if (o.detect_interval < 1) e << "detect_interval must be >= 1; ";
  if (!(o.min_cell_fill > 0.0 && o.min_cell_fill <= 1.0)) e << "min_cell_fill must be in (0, 1]; ";
  if (o.win_size < 5 || o.win_size % 2 == 0 || o.win_size > 101) e << "win_size must be odd in [5, 101]; ";
  if (o.max_level < 0 || o.max_level > 8) e << "max_level must be in [0, 8]; ";
  if (o.max_iterations < 1) e << "max_iterations must be >= 1; ";
  if (!(o.epsilon > 0.0) || !std::isfinite(o.epsilon)) e << "epsilon must be > 0; ";
  if (!(o.lk_min_eigenvalue >= 0.0) || !std::isfinite(o.lk_min_eigenvalue)) e << "lk_min_eigenvalue must be >= 0; ";
  if (!(o.fb_threshold_px > 0.0) || !std::isfinite(o.fb_threshold_px)) e << "fb_threshold_px must be > 0; ";
  if (!(o.max_patch_error >= 0.0) || !std::isfinite(o.max_patch_error)) e << "max_patch_error must be >= 0; ";
  if (o.fb_max_level < -1 || o.fb_max_level > 8) e << "fb_max_level must be in [-1, 8]; ";
  if (o.threads < 1) e << "threads must be >= 1; ";
  const std::string msg = e.str();
  if (msg.empty()) return true;
  if (why) *why = "invalid tracker options: " + msg.substr(0, msg.size() - 2);
  return false;
}

KltTracker::KltTracker(const KltTrackerOptions& options) : options_(options) {
  std::string why;
  if (!ValidateKltTrackerOptions(options_, &why)) throw std::invalid_argument(why);
  const int cells = options_.grid_cols * options_.grid_rows;
  quota_ = options_.max_per_cell > 0 ? options_.max_per_cell : (options_.max_tracks + cells - 1) / cells;
}

void KltTracker::Reset() {
  tracks_.clear();
  prev_pyramid_.clear();
  prev_gray_.release();
  size_ = cv::Size();
  frames_since_reset_ = 0;
  response_reference_ = 0.0;
}

int KltTracker::CellOf(const cv::Point2f& p) const {
  const int cx = std::clamp(static_cast<int>(p.x * options_.grid_cols / size_.width), 0, options_.grid_cols - 1);
  const int cy = std::clamp(static_cast<int>(p.y * options_.grid_rows / size_.height), 0, options_.grid_rows - 1);
  return cy * options_.grid_cols + cx;
}

TrackFrame KltTracker::Track(const ImageFrame& frame) {
  if (frame.image.empty()) throw std::invalid_argument("KltTracker::Track: empty image");
  if (frame.image.type() != CV_8UC1 && frame.image.type() != CV_8UC3)
    throw std::invalid_argument("KltTracker::Track: image must be CV_8UC1 or CV_8UC3");
  cv::setNumThreads(options_.threads);
  stats_ = KltTrackStats();

  cv::Mat gray;
  if (frame.image.channels() == 3) cv::cvtColor(frame.image, gray, cv::COLOR_BGR2GRAY);
  else gray = frame.image.clone();

  const cv::Size win(options_.win_size, options_.win_size);
  std::vector<cv::Mat> pyramid;
  // With derivatives: this pyramid is the "previous" one of the next frame, whose LK pass then reuses them.
  cv::buildOpticalFlowPyramid(gray, pyramid, win, options_.max_level, true);

  if (gray.size() != size_) {
    stats_.lost = static_cast<int>(tracks_.size());
    stats_.reset = true;
    Reset();
    size_ = gray.size();
  }

  const size_t n_prev = tracks_.size();
  if (n_prev > 0) {
    std::vector<cv::Point2f> prev_pts(n_prev), next_pts;
    for (size_t i = 0; i < n_prev; ++i) prev_pts[i] = tracks_[i].pt;
    std::vector<uchar> status;
    std::vector<float> err;
    const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, options_.max_iterations,
                                    options_.epsilon);
    cv::calcOpticalFlowPyrLK(prev_pyramid_, pyramid, prev_pts, next_pts, status, err, win, options_.max_level,
                             criteria, 0, options_.lk_min_eigenvalue);
    const float lo = static_cast<float>(options_.border_margin_px);
    const float hi_u = static_cast<float>(size_.width - 1 - options_.border_margin_px);
    const float hi_v = static_cast<float>(size_.height - 1 - options_.border_margin_px);
    std::vector<int> ok;
    ok.reserve(n_prev);
    for (size_t i = 0; i < n_prev; ++i) {
      const cv::Point2f& p = next_pts[i];
      if (options_.max_patch_error > 0.0 && !(err[i] <= options_.max_patch_error)) continue;
      if (status[i] && std::isfinite(p.x) && std::isfinite(p.y) && p.x >= lo && p.y >= lo && p.x <= hi_u &&
          p.y <= hi_v)
        ok.push_back(static_cast<int>(i));
    }
    std::vector<bool> keep(n_prev, false);
    if (options_.forward_backward_check && !ok.empty()) {
      std::vector<cv::Point2f> fwd(ok.size()), back(ok.size());
      for (size_t k = 0; k < ok.size(); ++k) {
        fwd[k] = next_pts[static_cast<size_t>(ok[k])];
        back[k] = prev_pts[static_cast<size_t>(ok[k])];
      }
      std::vector<uchar> back_status;
      const int fb_level = options_.fb_max_level >= 0 ? std::min(options_.fb_max_level, options_.max_level)
                                                      : options_.max_level;
      cv::calcOpticalFlowPyrLK(pyramid, prev_pyramid_, fwd, back, back_status, err, win, fb_level,
                               criteria, cv::OPTFLOW_USE_INITIAL_FLOW, options_.lk_min_eigenvalue);
      const double t2 = options_.fb_threshold_px * options_.fb_threshold_px;
      for (size_t k = 0; k < ok.size(); ++k) {
        const cv::Point2f d = back[k] - prev_pts[static_cast<size_t>(ok[k])];
        if (back_status[k] && static_cast<double>(d.x) * d.x + static_cast<double>(d.y) * d.y <= t2)
          keep[static_cast<size_t>(ok[k])] = true;
      }
    } else {
      for (int i : ok) keep[static_cast<size_t>(i)] = true;
    }
    std::vector<LiveTrack> survivors;
    survivors.reserve(n_prev);
    for (size_t i = 0; i < n_prev; ++i) {
      if (!keep[i]) continue;
      survivors.push_back({tracks_[i].id, next_pts[i], tracks_[i].age + 1});
    }
    RemoveDuplicates(&survivors);
    stats_.lost = static_cast<int>(n_prev - survivors.size());
    tracks_ = std::move(survivors);
  }

  const size_t before = tracks_.size();
  if (frames_since_reset_ % options_.detect_interval == 0 || tracks_.empty()) Detect(gray, &tracks_);
  stats_.born = static_cast<int>(tracks_.size() - before);

  prev_gray_ = gray;
  prev_pyramid_ = std::move(pyramid);
  ++frames_;
  ++frames_since_reset_;

  TrackFrame out;
  out.utime = frame.utime;
  out.seq = frame.seq;
  out.camera_name = frame.camera_name;
  out.width = size_.width;
  out.height = size_.height;
  out.features.reserve(tracks_.size());
  for (const LiveTrack& t : tracks_) out.features.push_back({t.id, t.pt.x, t.pt.y, t.age});
  stats_.live = static_cast<int>(out.features.size());
  return out;
}

void KltTracker::RemoveDuplicates(std::vector<LiveTrack>* tracks) const {
  if (options_.duplicate_distance_px <= 0.0 || tracks->size() < 2) return;
  // Older tracks win; among equals the smaller id. Survivors keep ascending id order.
  std::vector<size_t> order(tracks->size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    const LiveTrack& ta = (*tracks)[a];
    const LiveTrack& tb = (*tracks)[b];
    return ta.age != tb.age ? ta.age > tb.age : ta.id < tb.id;
  });
  PointBuckets buckets(size_, options_.duplicate_distance_px);
  std::vector<bool> keep(tracks->size(), false);
  for (size_t i : order) {
    const cv::Point2f& p = (*tracks)[i].pt;
    if (buckets.AnyWithin(p, options_.duplicate_distance_px)) continue;
    buckets.Insert(p);
    keep[i] = true;
  }
  std::vector<LiveTrack> out;
  out.reserve(tracks->size());
  for (size_t i = 0; i < tracks->size(); ++i)
    if (keep[i]) out.push_back((*tracks)[i]);
  *tracks = std::move(out);
}

void KltTracker::Detect(const cv::Mat& gray, std::vector<LiveTrack>* tracks) {
  if (static_cast<int>(tracks->size()) >= options_.max_tracks) return;
  const int cells = options_.grid_cols * options_.grid_rows;
  std::vector<int> count(static_cast<size_t>(cells), 0);
  for (const LiveTrack& t : *tracks) ++count[static_cast<size_t>(CellOf(t.pt))];
  const double fill_needed = options_.min_cell_fill * quota_;

  const int m = options_.border_margin_px;
  const cv::Rect inner(m, m, size_.width - 2 * m, size_.height - 2 * m);
  if (inner.width <= 0 || inner.height <= 0) return;

  // Cells whose inner part is non-empty and that are below quota.
  std::vector<int> deficient;
  std::vector<cv::Rect> cell_rect(static_cast<size_t>(cells));
  for (int cy = 0; cy < options_.grid_rows; ++cy) {
    for (int cx = 0; cx < options_.grid_cols; ++cx) {
      const int c = cy * options_.grid_cols + cx;
      // Pixel x belongs to cell floor(x * cols / width): cell cx covers [ceil(cx*W/cols), ceil((cx+1)*W/cols)).
      const int x0 = (cx * size_.width + options_.grid_cols - 1) / options_.grid_cols;
      const int x1 = ((cx + 1) * size_.width + options_.grid_cols - 1) / options_.grid_cols;
      const int y0 = (cy * size_.height + options_.grid_rows - 1) / options_.grid_rows;
      const int y1 = ((cy + 1) * size_.height + options_.grid_rows - 1) / options_.grid_rows;
      const cv::Rect r = cv::Rect(x0, y0, x1 - x0, y1 - y0) & inner;
      cell_rect[static_cast<size_t>(c)] = r;
      if (r.area() > 0 && count[static_cast<size_t>(c)] < fill_needed) deficient.push_back(c);
    }
  }
  if (deficient.empty()) return;
  stats_.detected = true;

  // Min-eigenvalue response per deficient cell (plus the filter apron; values inside the cell equal those of a
  // full-image computation because filters read the neighbouring pixels). Candidates: local maxima (3x3).
  const int apron = options_.corner_block_size / 2 + 2;
  const cv::Rect whole(0, 0, size_.width, size_.height);
  std::vector<std::vector<Candidate>> candidates(deficient.size());
  double max_response = 0.0;
  cv::Mat eig, dilated;
  for (size_t k = 0; k < deficient.size(); ++k) {
    const cv::Rect r = cell_rect[static_cast<size_t>(deficient[k])];
    const cv::Rect padded = cv::Rect(r.x - apron, r.y - apron, r.width + 2 * apron, r.height + 2 * apron) & whole;
    cv::cornerMinEigenVal(gray(padded), eig, options_.corner_block_size, 3);
    cv::dilate(eig, dilated, cv::Mat());
    const float floor = static_cast<float>(options_.min_eigenvalue);
    for (int y = r.y; y < r.y + r.height; ++y) {
      const float* e = eig.ptr<float>(y - padded.y);
      const float* d = dilated.ptr<float>(y - padded.y);
      for (int x = r.x; x < r.x + r.width; ++x) {
        const int xi = x - padded.x;
        if (e[xi] > 0.0f && e[xi] >= floor && e[xi] == d[xi]) {
          candidates[k].push_back({e[xi], x, y});
          max_response = std::max(max_response, static_cast<double>(e[xi]));
        }
      }
    }
  }
  // Quality threshold relative to the strongest response: that of the cells computed now, or the (slowly
  // decaying) reference from earlier frames, so that a lone weak cell does not accept noise as corners.
  response_reference_ = std::max(max_response, kResponseReferenceDecay * response_reference_);
  const float threshold =
      static_cast<float>(std::max(options_.quality_level * response_reference_, options_.min_eigenvalue));
  for (auto& list : candidates) {
    list.erase(std::remove_if(list.begin(), list.end(), [threshold](const Candidate& c) {
                 return c.response < threshold;
               }), list.end());
    // Strongest first; ties by row, then column.
    std::sort(list.begin(), list.end(), [](const Candidate& a, const Candidate& b) {
      return std::tie(b.response, a.y, a.x) < std::tie(a.response, b.y, b.x);
    });
  }

  PointBuckets occupied(size_, options_.min_distance_px);
  for (const LiveTrack& t : *tracks) occupied.Insert(t.pt);
  const bool use_distance = options_.min_distance_px > 0.0;
  const float lo = static_cast<float>(m);
  const float hi_u = static_cast<float>(size_.width - 1 - m);
  const float hi_v = static_cast<float>(size_.height - 1 - m);
  const int h = options_.subpix_half_window;
  const cv::TermCriteria subpix_criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.01);
  std::vector<cv::Point2f> refined(1);
  std::vector<size_t> next(deficient.size(), 0);
  int total = static_cast<int>(tracks->size());
  // Round robin over the deficient cells so that a global max_tracks cap does not starve the last cells. Each
  // candidate is refined to subpixel precision before it is accepted, so that the checks (border, cell quota,
  // distance to other tracks) hold for the position actually used.
  bool added = true;
  while (added && total < options_.max_tracks) {
    added = false;
    for (size_t k = 0; k < deficient.size() && total < options_.max_tracks; ++k) {
      if (count[static_cast<size_t>(deficient[k])] >= quota_) continue;
      auto& list = candidates[k];
      while (next[k] < list.size()) {
        const Candidate& c = list[next[k]++];
        cv::Point2f p(static_cast<float>(c.x), static_cast<float>(c.y));
        if (use_distance && occupied.AnyWithin(p, options_.min_distance_px)) continue;
        if (h > 0) {
          refined[0] = p;
          cv::cornerSubPix(gray, refined, cv::Size(h, h), cv::Size(-1, -1), subpix_criteria);
          const cv::Point2f q = refined[0];
          // A refinement that runs off (non-corner structure) keeps the integer maximum.
          if (std::isfinite(q.x) && std::isfinite(q.y) && std::abs(q.x - p.x) <= 1.0f && std::abs(q.y - p.y) <= 1.0f)
            p = q;
          if (p.x < lo || p.y < lo || p.x > hi_u || p.y > hi_v) continue;
          if (use_distance && occupied.AnyWithin(p, options_.min_distance_px)) continue;
        }
        int& n = count[static_cast<size_t>(CellOf(p))];
        if (n >= quota_) continue;
        occupied.Insert(p);
        tracks->push_back({next_id_++, p, 0});
        ++n;
        ++total;
        added = true;
        break;
      }
    }
  }
}

}  // namespace objscan
