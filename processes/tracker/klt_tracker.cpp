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
  // Radii up to `cell` can be queried; cells are at least 8 px so that tiny radii do not allocate huge grids.
  PointBuckets(cv::Size size, double cell) : cell_(std::max(cell, 8.0)) {
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
constexpr double kResponseReferenceDecay = 0.95;

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
  if (o.coarse_win_size != 0 && (o.coarse_win_size < 5 || o.coarse_win_size % 2 == 0 || o.coarse_win_size > o.win_size))
    e << "coarse_win_size must be 0 or odd in [5, win_size]; ";
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
  median_velocity_ = cv::Point2f();
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
  const int64 t_start = cv::getTickCount();

  cv::Mat gray;
  if (frame.image.channels() == 3)
    cv::cvtColor(frame.image, gray, cv::COLOR_BGR2GRAY);
  else
    gray = frame.image.clone();

  const cv::Size win(options_.win_size, options_.win_size);
  std::vector<cv::Mat> pyramid;
  // With derivatives: this pyramid is the "previous" one of the next frame, whose LK pass then reuses them.
  const int levels = cv::buildOpticalFlowPyramid(gray, pyramid, win, options_.max_level, true);

  const int64 t_pyramid = cv::getTickCount();
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
    // Motion prior: the track's last displacement (new tracks: the median of the last frame).
    std::vector<cv::Point2f> offset(n_prev);
    if (options_.predict_motion)
      for (size_t i = 0; i < n_prev; ++i) offset[i] = tracks_[i].age > 0 ? tracks_[i].velocity : median_velocity_;
    std::vector<uchar> keep;
    TrackAndCheck(prev_pyramid_, pyramid, prev_pts, offset, &next_pts, &keep);
    // Tracks that fail with a non-zero prior get a second chance without it (the camera may have stopped).
    std::vector<size_t> retry;
    for (size_t i = 0; i < n_prev; ++i)
      if (!keep[i] && offset[i] != cv::Point2f()) retry.push_back(i);
    if (!retry.empty()) {
      std::vector<cv::Point2f> retry_pts(retry.size()), retry_next;
      for (size_t k = 0; k < retry.size(); ++k) retry_pts[k] = prev_pts[retry[k]];
      std::vector<uchar> retry_keep;
      TrackAndCheck(prev_pyramid_, pyramid, retry_pts, std::vector<cv::Point2f>(retry.size()), &retry_next,
                    &retry_keep);
      for (size_t k = 0; k < retry.size(); ++k) {
        if (!retry_keep[k]) continue;
        keep[retry[k]] = 1;
        next_pts[retry[k]] = retry_next[k];
      }
    }
    std::vector<LiveTrack> survivors;
    survivors.reserve(n_prev);
    for (size_t i = 0; i < n_prev; ++i) {
      if (!keep[i]) continue;
      survivors.push_back({tracks_[i].id, next_pts[i], tracks_[i].age + 1, next_pts[i] - prev_pts[i]});
    }
    // Median displacement of the continued tracks: the motion prior of tracks born in this frame.
    if (!survivors.empty()) {
      std::vector<float> dx(survivors.size()), dy(survivors.size());
      for (size_t k = 0; k < survivors.size(); ++k) {
        dx[k] = survivors[k].velocity.x;
        dy[k] = survivors[k].velocity.y;
      }
      const auto mid = static_cast<std::ptrdiff_t>(dx.size() / 2);
      std::nth_element(dx.begin(), dx.begin() + mid, dx.end());
      std::nth_element(dy.begin(), dy.begin() + mid, dy.end());
      median_velocity_ = cv::Point2f(dx[static_cast<size_t>(mid)], dy[static_cast<size_t>(mid)]);
    }
    RemoveDuplicates(&survivors);
    stats_.lost = static_cast<int>(n_prev - survivors.size());
    tracks_ = std::move(survivors);
  }

  const int64 t_lk = cv::getTickCount();
  const size_t before = tracks_.size();
  if (frames_since_reset_ % options_.detect_interval == 0 || tracks_.empty()) Detect(gray, &tracks_);
  stats_.born = static_cast<int>(tracks_.size() - before);
  const int64 t_detect = cv::getTickCount();
  const double tick_ms = 1e3 / cv::getTickFrequency();
  stats_.pyramid_ms = static_cast<double>(t_pyramid - t_start) * tick_ms;
  stats_.lk_ms = static_cast<double>(t_lk - t_pyramid) * tick_ms;
  stats_.detect_ms = static_cast<double>(t_detect - t_lk) * tick_ms;

  prev_gray_ = gray;
  prev_pyramid_ = std::move(pyramid);
  levels_ = levels;
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

void KltTracker::TrackAndCheck(const std::vector<cv::Mat>& from_pyramid, const std::vector<cv::Mat>& to_pyramid,
                               const std::vector<cv::Point2f>& pts, const std::vector<cv::Point2f>& offset,
                               std::vector<cv::Point2f>* out, std::vector<uchar>* keep) const {
  const size_t n = pts.size();
  std::vector<cv::Point2f> start(n);
  for (size_t i = 0; i < n; ++i) start[i] = pts[i] + offset[i];
  std::vector<uchar> status;
  std::vector<float> err;
  TrackPoints(from_pyramid, to_pyramid, pts, &start, out, &status, &err);
  const float lo = static_cast<float>(options_.border_margin_px);
  const float hi_u = static_cast<float>(size_.width - 1 - options_.border_margin_px);
  const float hi_v = static_cast<float>(size_.height - 1 - options_.border_margin_px);
  keep->assign(n, 0);
  std::vector<size_t> ok;
  ok.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const cv::Point2f& p = (*out)[i];
    if (options_.max_patch_error > 0.0 && !(err[i] <= options_.max_patch_error)) continue;
    if (status[i] && std::isfinite(p.x) && std::isfinite(p.y) && p.x >= lo && p.y >= lo && p.x <= hi_u && p.y <= hi_v)
      ok.push_back(i);
  }
  if (!options_.forward_backward_check) {
    for (size_t i : ok) (*keep)[i] = 1;
    return;
  }
  if (ok.empty()) return;
  // The backward pass searches like the forward pass did, with the same motion prior reversed (no hint of where
  // home is beyond that).
  std::vector<cv::Point2f> fwd(ok.size()), back_start(ok.size()), back;
  for (size_t k = 0; k < ok.size(); ++k) {
    fwd[k] = (*out)[ok[k]];
    back_start[k] = fwd[k] - offset[ok[k]];
  }
  std::vector<uchar> back_status;
  TrackPoints(to_pyramid, from_pyramid, fwd, &back_start, &back, &back_status, &err);
  const double t2 = options_.fb_threshold_px * options_.fb_threshold_px;
  for (size_t k = 0; k < ok.size(); ++k) {
    const cv::Point2f d = back[k] - pts[ok[k]];
    if (back_status[k] && static_cast<double>(d.x) * d.x + static_cast<double>(d.y) * d.y <= t2) (*keep)[ok[k]] = 1;
  }
}

void KltTracker::TrackPoints(const std::vector<cv::Mat>& from, const std::vector<cv::Mat>& to,
                             const std::vector<cv::Point2f>& pts, const std::vector<cv::Point2f>* initial,
                             std::vector<cv::Point2f>* out, std::vector<uchar>* status, std::vector<float>* err) const {
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, options_.max_iterations,
                                  options_.epsilon);
  const cv::Size win(options_.win_size, options_.win_size);
  const size_t n = pts.size();
  if (options_.coarse_win_size <= 0 || levels_ < 1) {
    *out = initial ? *initial : pts;
    cv::calcOpticalFlowPyrLK(from, to, pts, *out, *status, *err, win, levels_, criteria, cv::OPTFLOW_USE_INITIAL_FLOW,
                             options_.lk_min_eigenvalue);
    return;
  }
  // Coarse to fine in two calls: levels levels_..1 with the small coarse window (the pyramids without their base,
  // so coordinates are halved), then the base level alone with the full window from that initial flow. The big
  // window makes the final position accurate; the coarse levels only have to get within its reach.
  const std::vector<cv::Mat> from_coarse(from.begin() + 2, from.end());
  const std::vector<cv::Mat> to_coarse(to.begin() + 2, to.end());
  std::vector<cv::Point2f> half(n), half_out(n);
  for (size_t i = 0; i < n; ++i) {
    half[i] = pts[i] * 0.5f;
    half_out[i] = (initial ? (*initial)[i] : pts[i]) * 0.5f;
  }
  std::vector<uchar> coarse_status;
  const cv::Size coarse_win(options_.coarse_win_size, options_.coarse_win_size);
  cv::calcOpticalFlowPyrLK(from_coarse, to_coarse, half, half_out, coarse_status, *err, coarse_win, levels_ - 1,
                           criteria, cv::OPTFLOW_USE_INITIAL_FLOW, options_.lk_min_eigenvalue);
  out->resize(n);
  for (size_t i = 0; i < n; ++i) (*out)[i] = coarse_status[i] ? half_out[i] * 2.0f : pts[i];
  cv::calcOpticalFlowPyrLK(from, to, pts, *out, *status, *err, win, 0, criteria, cv::OPTFLOW_USE_INITIAL_FLOW,
                           options_.lk_min_eigenvalue);
  for (size_t i = 0; i < n; ++i) (*status)[i] = (*status)[i] && coarse_status[i];
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
  int total = static_cast<int>(tracks->size());
  if (total >= options_.max_tracks) return;
  const int cells = options_.grid_cols * options_.grid_rows;
  std::vector<int> count(static_cast<size_t>(cells), 0);
  for (const LiveTrack& t : *tracks) ++count[static_cast<size_t>(CellOf(t.pt))];
  const double fill_needed = options_.min_cell_fill * quota_;

  const int m = options_.border_margin_px;
  const cv::Rect inner(m, m, size_.width - 2 * m, size_.height - 2 * m);
  if (inner.width <= 0 || inner.height <= 0) return;

  // Cells whose inner part is non-empty and that are below quota (triggered by one below min_cell_fill).
  std::vector<int> deficient;
  std::vector<cv::Rect> cell_rect(static_cast<size_t>(cells));
  bool triggered = false;
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
      if (r.area() <= 0 || count[static_cast<size_t>(c)] >= quota_) continue;
      deficient.push_back(c);
      if (count[static_cast<size_t>(c)] < fill_needed) triggered = true;
    }
  }
  if (deficient.empty() || !triggered) return;
  stats_.detected = true;
  // Emptiest cells first (ties: cell index), so that a small budget goes where tracks are missing most.
  std::stable_sort(deficient.begin(), deficient.end(),
                   [&count](int a, int b) { return count[static_cast<size_t>(a)] < count[static_cast<size_t>(b)]; });

  // Shi-Tomasi candidates of one cell, computed when the cell is first visited: min-eigenvalue response on the cell
  // plus the filter apron (values inside the cell equal those of a full-image computation because the filters read
  // the neighbouring pixels), local maxima (3x3) above the absolute floor, strongest first (ties: row, column).
  const int apron = options_.corner_block_size / 2 + 2;
  const cv::Rect whole(0, 0, size_.width, size_.height);
  const float floor = static_cast<float>(options_.min_eigenvalue);
  cv::Mat eig, dilated;
  response_reference_ *= kResponseReferenceDecay;
  auto compute = [&](int c, std::vector<Candidate>* list) {
    const cv::Rect r = cell_rect[static_cast<size_t>(c)];
    const cv::Rect padded = cv::Rect(r.x - apron, r.y - apron, r.width + 2 * apron, r.height + 2 * apron) & whole;
    cv::cornerMinEigenVal(gray(padded), eig, options_.corner_block_size, 3);
    cv::dilate(eig, dilated, cv::Mat());
    for (int y = r.y; y < r.y + r.height; ++y) {
      const float* e = eig.ptr<float>(y - padded.y);
      const float* d = dilated.ptr<float>(y - padded.y);
      for (int x = r.x; x < r.x + r.width; ++x) {
        const int xi = x - padded.x;
        if (e[xi] > 0.0f && e[xi] >= floor && e[xi] == d[xi]) list->push_back({e[xi], x, y});
      }
    }
    std::sort(list->begin(), list->end(), [](const Candidate& a, const Candidate& b) {
      return std::tie(b.response, a.y, a.x) < std::tie(a.response, b.y, b.x);
    });
    if (!list->empty())
      response_reference_ = std::max(response_reference_, static_cast<double>(list->front().response));
  };
  std::vector<std::vector<Candidate>> candidates(deficient.size());
  std::vector<bool> computed(deficient.size(), false);
  // Right after a reset there is no reference response yet: compute every cell first so that the quality threshold
  // is relative to the strongest corner of the whole frame, as in goodFeaturesToTrack.
  if (frames_since_reset_ == 0) {
    for (size_t k = 0; k < deficient.size(); ++k) {
      compute(deficient[k], &candidates[k]);
      computed[k] = true;
    }
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
  // Water filling: in round `level`, every cell holding fewer than `level` tracks gets one more (if it has a
  // usable corner). Each candidate is refined to subpixel precision before it is accepted, so that the checks
  // (border, cell quota, distance to other tracks) hold for the position actually used.
  const int start_level = count[static_cast<size_t>(deficient.front())] + 1;
  for (int level = start_level; level <= quota_ && total < options_.max_tracks; ++level) {
    for (size_t k = 0; k < deficient.size() && total < options_.max_tracks; ++k) {
      int& n_cell = count[static_cast<size_t>(deficient[k])];
      if (n_cell >= level) continue;
      if (!computed[k]) {
        compute(deficient[k], &candidates[k]);
        computed[k] = true;
      }
      const float threshold =
          static_cast<float>(std::max(options_.quality_level * response_reference_, options_.min_eigenvalue));
      const auto& list = candidates[k];
      while (next[k] < list.size()) {
        const Candidate& c = list[next[k]++];
        if (c.response < threshold) {
          next[k] = list.size();  // sorted: the rest are weaker still
          break;
        }
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
        tracks->push_back({next_id_++, p, 0, cv::Point2f()});
        ++n;
        ++total;
        break;
      }
    }
  }
}

}  // namespace objscan
