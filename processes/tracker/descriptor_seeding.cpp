#include "processes/tracker/descriptor_seeding.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <unordered_set>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace objscan {

bool ParseDescriptorKind(const std::string& name, DescriptorKind* kind) {
  if (name == "sift")
    *kind = DescriptorKind::kSift;
  else if (name == "akaze")
    *kind = DescriptorKind::kAkaze;
  else if (name == "orb")
    *kind = DescriptorKind::kOrb;
  else
    return false;
  return true;
}

const char* DescriptorKindName(DescriptorKind kind) {
  switch (kind) {
    case DescriptorKind::kSift:
      return "sift";
    case DescriptorKind::kAkaze:
      return "akaze";
    case DescriptorKind::kOrb:
      return "orb";
  }
  return "?";
}

bool ValidateDescriptorTrackerOptions(const DescriptorTrackerOptions& o, std::string* why) {
  std::ostringstream e;
  if (o.max_features < 8) e << "max_features must be >= 8; ";
  if (o.border_margin_px < 0) e << "border_margin_px must be >= 0; ";
  if (!(o.sift_contrast_threshold > 0)) e << "sift_contrast_threshold must be > 0; ";
  if (!(o.akaze_threshold > 0)) e << "akaze_threshold must be > 0; ";
  if (!(o.clahe_clip_limit >= 0)) e << "clahe_clip_limit must be >= 0; ";
  if (!(o.ratio > 0 && o.ratio <= 1)) e << "ratio must be in (0, 1]; ";
  if (!(o.ransac_threshold_px > 0)) e << "ransac_threshold_px must be > 0; ";
  if (!(o.ransac_confidence > 0 && o.ransac_confidence < 1)) e << "ransac_confidence must be in (0, 1); ";
  if (o.min_inliers < 8) e << "min_inliers must be >= 8; ";
  if (o.history_frames < 1 || o.history_frames > 10) e << "history_frames must be in [1, 10]; ";
  if (o.threads < 1) e << "threads must be >= 1; ";
  const std::string msg = e.str();
  if (msg.empty()) return true;
  if (why) *why = msg.substr(0, msg.size() - 2);
  return false;
}

namespace {

double MillisSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Best and second-best train index per query row (second = -1 when train has one row).
void TwoNearest(const cv::Mat& query, const cv::Mat& train, int norm, std::vector<int>* best,
                std::vector<float>* best_d, std::vector<float>* second_d) {
  best->assign(query.rows, -1);
  best_d->assign(query.rows, 0);
  second_d->assign(query.rows, std::numeric_limits<float>::infinity());
  if (query.empty() || train.empty()) return;
  cv::BFMatcher matcher(norm, false);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(query, train, knn, 2);
  for (const auto& m : knn) {
    if (m.empty()) continue;
    (*best)[m[0].queryIdx] = m[0].trainIdx;
    (*best_d)[m[0].queryIdx] = m[0].distance;
    if (m.size() > 1) (*second_d)[m[0].queryIdx] = m[1].distance;
  }
}

// L2 (float descriptors): one distance matrix |q|^2 + |t|^2 - 2 q.t (a single GEMM, ~10x faster than brute force
// per pair) gives both directions; distances as BFMatcher reports them (not squared).
void TwoNearestL2(const cv::Mat& query, const cv::Mat& train, bool backward, std::vector<int>* fwd,
                  std::vector<float>* fd, std::vector<float>* fs, std::vector<int>* bwd) {
  const float inf = std::numeric_limits<float>::infinity();
  fwd->assign(query.rows, -1);
  fd->assign(query.rows, 0);
  fs->assign(query.rows, inf);
  bwd->assign(train.rows, -1);
  if (query.empty() || train.empty()) return;
  cv::Mat q, t;
  query.convertTo(q, CV_32F);
  train.convertTo(t, CV_32F);
  cv::Mat qt;
  cv::gemm(q, t, -2.0, cv::noArray(), 0.0, qt, cv::GEMM_2_T);
  cv::Mat q2, t2;
  cv::reduce(q.mul(q), q2, 1, cv::REDUCE_SUM);
  cv::reduce(t.mul(t), t2, 1, cv::REDUCE_SUM);
  std::vector<float> col_best(train.rows, inf);
  for (int i = 0; i < q.rows; ++i) {
    const float* row = qt.ptr<float>(i);
    const float qi = q2.at<float>(i);
    float b1 = inf, b2 = inf;
    int j1 = -1;
    for (int j = 0; j < t.rows; ++j) {
      const float d = std::max(0.0f, qi + t2.at<float>(j) + row[j]);
      if (d < b1) {
        b2 = b1;
        b1 = d;
        j1 = j;
      } else if (d < b2) {
        b2 = d;
      }
      if (backward && d < col_best[j]) {
        col_best[j] = d;
        (*bwd)[j] = i;
      }
    }
    (*fwd)[i] = j1;
    (*fd)[i] = std::sqrt(b1);
    (*fs)[i] = std::sqrt(b2);
  }
}

}  // namespace

std::vector<std::pair<int, int>> MatchDescriptors(const cv::Mat& query, const cv::Mat& train, int norm, double ratio,
                                                  bool mutual_check) {
  std::vector<int> fwd, bwd;
  std::vector<float> fd, fs, bd, bs;
  if (norm == cv::NORM_L2) {
    TwoNearestL2(query, train, mutual_check, &fwd, &fd, &fs, &bwd);
  } else {
    TwoNearest(query, train, norm, &fwd, &fd, &fs);
    if (mutual_check) TwoNearest(train, query, norm, &bwd, &bd, &bs);
  }
  std::vector<std::pair<int, int>> out;
  for (int q = 0; q < query.rows; ++q) {
    const int t = fwd[q];
    if (t < 0) continue;
    if (!(fd[q] < ratio * fs[q])) continue;
    if (mutual_check && bwd[t] != q) continue;
    out.emplace_back(q, t);
  }
  return out;
}

DescriptorTracker::DescriptorTracker(const DescriptorTrackerOptions& options) : options_(options) {
  std::string why;
  if (!ValidateDescriptorTrackerOptions(options_, &why)) throw std::invalid_argument("descriptor tracker: " + why);
  switch (options_.kind) {
    case DescriptorKind::kSift:
      feature_ = cv::SIFT::create(0, 3, options_.sift_contrast_threshold);
      norm_ = cv::NORM_L2;
      break;
    case DescriptorKind::kAkaze:
      feature_ = cv::AKAZE::create(cv::AKAZE::DESCRIPTOR_MLDB, 0, 3, static_cast<float>(options_.akaze_threshold));
      norm_ = cv::NORM_HAMMING;
      break;
    case DescriptorKind::kOrb:
      feature_ = cv::ORB::create(options_.max_features * 2);
      norm_ = cv::NORM_HAMMING;
      break;
  }
}

void DescriptorTracker::Reset() {
  history_.clear();
  size_ = cv::Size();
}

void DescriptorTracker::Describe(const cv::Mat& gray, std::vector<cv::KeyPoint>* keypoints, cv::Mat* descriptors) {
  keypoints->clear();
  feature_->detect(gray, *keypoints);
  const float m = static_cast<float>(options_.border_margin_px);
  const float w = static_cast<float>(gray.cols) - 1 - m, h = static_cast<float>(gray.rows) - 1 - m;
  keypoints->erase(
      std::remove_if(keypoints->begin(), keypoints->end(),
                     [&](const cv::KeyPoint& k) { return k.pt.x < m || k.pt.y < m || k.pt.x > w || k.pt.y > h; }),
      keypoints->end());
  // Deterministic order (detectors may collect keypoints from parallel workers): strongest first, then position.
  std::stable_sort(keypoints->begin(), keypoints->end(), [](const cv::KeyPoint& a, const cv::KeyPoint& b) {
    if (a.response != b.response) return a.response > b.response;
    if (a.pt.y != b.pt.y) return a.pt.y < b.pt.y;
    if (a.pt.x != b.pt.x) return a.pt.x < b.pt.x;
    if (a.size != b.size) return a.size < b.size;
    return a.angle < b.angle;
  });
  if (static_cast<int>(keypoints->size()) > options_.max_features) keypoints->resize(options_.max_features);
  feature_->compute(gray, *keypoints, *descriptors);  // may drop keypoints it cannot describe
}

cv::Mat DescriptorTracker::PrepareGray(const cv::Mat& image) const {
  if (image.empty()) throw std::invalid_argument("descriptor tracker: empty image");
  if (image.type() != CV_8UC1 && image.type() != CV_8UC3)
    throw std::invalid_argument("descriptor tracker: image must be CV_8UC1 or CV_8UC3");
  cv::Mat gray;
  if (image.type() == CV_8UC3)
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  else
    gray = image;
  if (options_.clahe_clip_limit > 0) {
    cv::Mat equalized;
    cv::createCLAHE(options_.clahe_clip_limit, cv::Size(8, 8))->apply(gray, equalized);
    gray = equalized;
  }
  return gray;
}

DescriptorTracker::DescribedImage DescriptorTracker::DescribeImage(const cv::Mat& image) {
  const cv::Mat gray = PrepareGray(image);
  cv::setNumThreads(options_.threads);
  return DescribeGray(gray);
}

DescriptorTracker::DescribedImage DescriptorTracker::DescribeGray(const cv::Mat& gray) {
  std::vector<cv::KeyPoint> keypoints;
  DescribedImage out;
  Describe(gray, &keypoints, &out.descriptors);
  // OpenCV's SIFT detects on a 2x upsampled base image (cv::resize, pixel-centre convention: x2 = 2x + 0.5) and
  // halves the coordinates without removing the half-pixel shift: its keypoints sit +0.25 px off in u and v (measured
  // in descriptor_seeding_test through a 180 deg turn, where the bias doubles). Removed here.
  const float shift = options_.kind == DescriptorKind::kSift ? -0.25f : 0.0f;
  out.points.reserve(keypoints.size());
  for (const cv::KeyPoint& k : keypoints) out.points.push_back(k.pt + cv::Point2f(shift, shift));
  return out;
}

std::vector<std::pair<int, int>> DescriptorTracker::VerifiedMatches(const std::vector<cv::Point2f>& query_points,
                                                                    const cv::Mat& query_descriptors,
                                                                    const std::vector<cv::Point2f>& train_points,
                                                                    const cv::Mat& train_descriptors,
                                                                    std::vector<uchar>* inlier) const {
  std::vector<std::pair<int, int>> matches =
      MatchDescriptors(query_descriptors, train_descriptors, norm_, options_.ratio, options_.mutual_check);
  std::vector<uchar> mask(matches.size(), 0);
  if (static_cast<int>(matches.size()) >= options_.min_inliers) {
    std::vector<cv::Point2f> a, b;
    for (const auto& [q, t] : matches) {
      a.push_back(query_points[q]);
      b.push_back(train_points[t]);
    }
    std::vector<uchar> ransac;
    const cv::Mat f = cv::findFundamentalMat(a, b, cv::FM_RANSAC, options_.ransac_threshold_px,
                                             options_.ransac_confidence, 5000, ransac);
    if (!f.empty() && ransac.size() == matches.size() && cv::countNonZero(ransac) >= options_.min_inliers)
      mask = std::move(ransac);
  }
  if (inlier) *inlier = std::move(mask);
  return matches;
}

TrackFrame DescriptorTracker::Track(const ImageFrame& frame) {
  const cv::Mat gray = PrepareGray(frame.image);
  cv::setNumThreads(options_.threads);
  stats_ = DescriptorTrackStats();
  if (gray.size() != size_) history_.clear();
  size_ = gray.size();

  auto t0 = std::chrono::steady_clock::now();
  StoredFrame cur;
  DescribedImage described = DescribeGray(gray);
  cur.points = std::move(described.points);
  cur.descriptors = described.descriptors;
  const int n = static_cast<int>(cur.points.size());
  stats_.keypoints = n;
  stats_.detect_ms = MillisSince(t0);
  cur.ids.assign(n, -1);
  cur.birth.assign(n, frames_);

  t0 = std::chrono::steady_clock::now();
  std::unordered_set<int64_t> used;  // ids already given to a keypoint of this frame
  for (size_t h = 0; h < history_.size(); ++h) {
    const StoredFrame& old = history_[h];
    std::vector<uchar> mask;
    const std::vector<std::pair<int, int>> matches =
        VerifiedMatches(cur.points, cur.descriptors, old.points, old.descriptors, &mask);
    stats_.raw_matches.push_back(static_cast<int>(matches.size()));
    const int inliers = mask.empty() ? 0 : cv::countNonZero(mask);
    stats_.inliers.push_back(inliers);
    if (inliers == 0) continue;
    for (size_t k = 0; k < matches.size(); ++k) {
      if (!mask[k]) continue;
      const auto [q, t] = matches[k];
      if (cur.ids[q] >= 0 || used.count(old.ids[t])) continue;  // newer frames and earlier claims win
      cur.ids[q] = old.ids[t];
      cur.birth[q] = old.birth[t];
      used.insert(old.ids[t]);
      ++stats_.continued;
      if (h > 0) ++stats_.bridged;
    }
  }
  for (int i = 0; i < n; ++i) {
    if (cur.ids[i] >= 0) continue;
    cur.ids[i] = next_id_++;
    ++stats_.born;
  }
  stats_.match_ms = MillisSince(t0);

  TrackFrame out;
  out.utime = frame.utime;
  out.seq = frame.seq;
  out.camera_name = frame.camera_name;
  out.width = gray.cols;
  out.height = gray.rows;
  out.features.resize(n);
  for (int i = 0; i < n; ++i) {
    TrackedFeature& t = out.features[i];
    t.id = cur.ids[i];
    t.u = cur.points[i].x;
    t.v = cur.points[i].y;
    t.age = frames_ - cur.birth[i];
  }
  std::sort(out.features.begin(), out.features.end(),
            [](const TrackedFeature& x, const TrackedFeature& y) { return x.id < y.id; });

  history_.push_front(std::move(cur));
  while (static_cast<int>(history_.size()) > options_.history_frames) history_.pop_back();
  ++frames_;
  return out;
}

}  // namespace objscan
