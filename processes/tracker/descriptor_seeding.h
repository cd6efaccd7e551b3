// Descriptor tracker (LCM-free): feature tracks for wide-baseline image sequences (turntables, sparse rings) where
// the frame-to-frame motion is too large for KLT. Every frame: keypoints + descriptors (SIFT, AKAZE or ORB), matched
// against the stored keypoints of the last `history_frames` frames (newest first) with Lowe's ratio test, a mutual
// (cross) check and a fundamental-matrix RANSAC per frame pair. A keypoint matched to a stored keypoint inherits its
// track id; matching the frame two back lets a track bridge one frame where its keypoint was not matched. Unmatched
// keypoints start new tracks. A track id appears at most once per frame.
//
// Track positions are the keypoints' own sub-pixel positions in each frame (every observation is a detection, so
// there is no drift; the accuracy is the detector's repeatability, typically a few tenths of a pixel for SIFT).
// Kind: SIFT (default) is the one that works on the Middlebury sparse rings (processes/pose_solver/
// middlebury_pose_test.cpp): AKAZE carries fewer and less accurate tracks (0.7 px vs 0.16 px repeatability in
// descriptor_seeding_test), ORB's pyramid shifts its keypoints by up to ~1 px and it failed on both rings.
// Pixel convention: (u, v) = (column, row), origin at the centre of the top-left pixel (OpenCV keypoints).
// Not thread-safe; one instance per image stream. Deterministic for a fixed options.threads (keypoints are sorted
// before description, RANSAC uses OpenCV's fixed seed). Output order = ascending track id.
#pragma once

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "common/sensor_data.h"

namespace objscan {

enum class DescriptorKind { kSift, kAkaze, kOrb };
// "sift" | "akaze" | "orb" -> kind; false on anything else.
bool ParseDescriptorKind(const std::string& name, DescriptorKind* kind);
const char* DescriptorKindName(DescriptorKind kind);

struct DescriptorTrackerOptions {
  DescriptorKind kind = DescriptorKind::kSift;  // detector + descriptor
  int max_features = 1500;                      // keypoints kept per frame (strongest response first)
  int border_margin_px = 8;                     // px, keypoints closer than this to the image border are ignored
  double sift_contrast_threshold = 0.005;       // SIFT contrast threshold (OpenCV default 0.04; lower = more keypoints;
                                                // the weakly textured Middlebury objects need ~0.005)
  double akaze_threshold = 0.0005;              // AKAZE detector response threshold (OpenCV default 0.001)
  double clahe_clip_limit = 0.0;     // > 0: contrast-limited histogram equalization (8x8 tiles, this clip limit)
                                     // before detection, for dark / low-contrast images; 0 = off
  double ratio = 0.8;                // Lowe's ratio test: best / second-best descriptor distance < ratio, (0, 1]
  bool mutual_check = true;          // keep a match only when it is also the best match in the other direction
  double ransac_threshold_px = 1.5;  // px, fundamental-matrix RANSAC inlier distance (point to epipolar line)
  double ransac_confidence = 0.999;  // RANSAC confidence, (0, 1)
  int min_inliers = 15;              // fewer F-RANSAC inliers for a frame pair = no ids carried from that frame
  int history_frames = 2;            // earlier frames matched against (1 = previous only, 2 = also the one before)
  int threads = 1;                   // cv::setNumThreads value set on every Track() call (>= 1)
};
bool ValidateDescriptorTrackerOptions(const DescriptorTrackerOptions& options, std::string* why);

// Figures of the most recent Track() call.
struct DescriptorTrackStats {
  int keypoints = 0;             // keypoints described in this frame
  std::vector<int> raw_matches;  // per history frame (newest first): matches passing ratio + mutual check
  std::vector<int> inliers;      // per history frame: F-RANSAC inliers (0 when below min_inliers or no RANSAC)
  int continued = 0;             // features carrying an existing track id
  int bridged = 0;               // of those: ids taken from a frame older than the previous one
  int born = 0;                  // new track ids
  double detect_ms = 0;          // ms (wall clock), detection and description
  double match_ms = 0;           // ms (wall clock), matching and RANSAC
};

// Matches two descriptor sets: ratio test (query -> train, k = 2) plus optional mutual check. Returns pairs
// (query index, train index) sorted by query index. norm: cv::NORM_L2 or cv::NORM_HAMMING.
std::vector<std::pair<int, int>> MatchDescriptors(const cv::Mat& query, const cv::Mat& train, int norm, double ratio,
                                                  bool mutual_check);

class DescriptorTracker {
 public:
  // Throws std::invalid_argument when the options do not validate.
  explicit DescriptorTracker(const DescriptorTrackerOptions& options = {});

  // Detects, describes and matches this frame (CV_8UC1 gray or CV_8UC3 BGR) against the stored frames and returns
  // its features (one per keypoint) with track ids. utime/seq/camera_name are copied from the input. A frame whose
  // size differs from the previous one only starts new tracks. Throws std::invalid_argument on an empty image or
  // another pixel type; the state is unchanged then.
  TrackFrame Track(const ImageFrame& frame);

  // Forgets the stored frames (ids keep counting up; they are never reused).
  void Reset();

  // One image's keypoints (px, bias-corrected) and descriptors exactly as Track() computes them; no tracker state is
  // touched. Throws std::invalid_argument on an empty image or another pixel type.
  struct DescribedImage {
    std::vector<cv::Point2f> points;
    cv::Mat descriptors;  // one row per point
  };
  DescribedImage DescribeImage(const cv::Mat& image);
  // Matches of query against train that pass Track()'s checks (ratio test, mutual check, fundamental-matrix RANSAC
  // of ransac_threshold_px); *inlier (optional) gets one flag per returned raw match. Returns the raw matches
  // (query index, train index); the verified ones are those flagged, none when fewer than min_inliers pass.
  std::vector<std::pair<int, int>> VerifiedMatches(const std::vector<cv::Point2f>& query_points,
                                                   const cv::Mat& query_descriptors,
                                                   const std::vector<cv::Point2f>& train_points,
                                                   const cv::Mat& train_descriptors, std::vector<uchar>* inlier) const;

  // Ids start at first_id (call before the first Track; lets a second tracker use a disjoint id range).
  void set_first_id(int64_t first_id) { next_id_ = first_id; }

  const DescriptorTrackerOptions& options() const { return options_; }
  const DescriptorTrackStats& last_stats() const { return stats_; }
  int64_t next_id() const { return next_id_; }

 private:
  struct StoredFrame {
    std::vector<cv::Point2f> points;  // px
    std::vector<int64_t> ids;         // track id per keypoint
    std::vector<int32_t> birth;       // frame index at which the track was born
    cv::Mat descriptors;              // one row per keypoint
  };
  void Describe(const cv::Mat& gray, std::vector<cv::KeyPoint>* keypoints, cv::Mat* descriptors);
  // Gray (and CLAHE-equalized when configured) copy of a CV_8UC1 / CV_8UC3 image; throws on others.
  cv::Mat PrepareGray(const cv::Mat& image) const;
  DescribedImage DescribeGray(const cv::Mat& gray);

  DescriptorTrackerOptions options_;
  cv::Ptr<cv::Feature2D> feature_;
  int norm_ = cv::NORM_L2;
  int64_t next_id_ = 0;
  int32_t frames_ = 0;
  cv::Size size_;
  std::deque<StoredFrame> history_;  // newest first
  DescriptorTrackStats stats_;
};

}  // namespace objscan
