#include "drivers/camera/frame_source.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <sstream>

#include "common/recorded_run.h"

namespace objscan {
namespace fs = std::filesystem;

namespace {

bool Fail(std::string* error, const std::string& text) {
  if (error) *error = text;
  return false;
}

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string Trim(const std::string& s) {
  const auto begin = s.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return "";
  const auto end = s.find_last_not_of(" \t\r\n");
  return s.substr(begin, end - begin + 1);
}

bool ParseDouble(const std::string& text, double* out) {
  if (text.empty()) return false;
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (errno != 0 || *end != '\0' || !std::isfinite(v)) return false;
  *out = v;
  return true;
}

bool IsAllDigits(const std::string& s) {
  return !s.empty() &&
         std::all_of(s.begin(), s.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); });
}

std::string SizeText(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

// Nearest rotation matrix (Frobenius) to m.
Eigen::Matrix3d NearestRotation(const Eigen::Matrix3d& m) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1 : 1;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

// Checks that the camera is valid and its principal point lies in the image.
bool CheckCamera(const PinholeCamera& c, const std::string& where, std::string* error) {
  std::string why;
  if (!CheckMetricCamera(c, &why)) return Fail(error, where + ": " + why);
  return true;
}

// Reads an image as 8-bit gray or BGR (alpha dropped, 16-bit scaled down). Empty on failure.
cv::Mat ReadImage8(const std::string& path) {
  cv::Mat image;
  try {
    image = cv::imread(path, cv::IMREAD_ANYCOLOR);
  } catch (const cv::Exception&) {
    return cv::Mat();
  }
  if (image.empty()) return image;
  if (image.channels() == 4) cv::cvtColor(image, image, cv::COLOR_BGRA2BGR);
  if (image.channels() != 1 && image.channels() != 3) return cv::Mat();
  if (image.depth() != CV_8U) return cv::Mat();
  return image;
}

// ---------------------------------------------------------------------------------------------------------------
// Folder-like sources (image folder, Middlebury): a list of files read lazily in a given order.

struct ListEntry {
  std::string path;      // full path of the image file
  std::string name;      // file name
  PinholeCamera camera;  // this view's intrinsics (same for all entries of an image folder)
  bool has_pose = false;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();  // mm
  int64_t recorded_utime = -1;  // µs, from timestamps.txt (-1: none)
};

class ListFrameSource final : public FrameSource {
 public:
  ListFrameSource(SourceKind kind, std::string root, std::vector<ListEntry> entries, std::vector<int> sequence,
                  std::vector<bool> rotate, int width, int height, std::string note)
      : kind_(kind),
        root_(std::move(root)),
        entries_(std::move(entries)),
        sequence_(std::move(sequence)),
        rotate_(std::move(rotate)),
        width_(width),
        height_(height),
        note_(std::move(note)) {}

  ReadResult Next(SourceFrame* frame, std::string* reason, std::string* detail) override {
    if (position_ >= sequence_.size()) return ReadResult::kEnd;
    const int index = sequence_[position_++];
    const ListEntry& entry = entries_[static_cast<size_t>(index)];
    cv::Mat image = ReadImage8(entry.path);
    if (image.empty()) {
      *reason = "frame: unreadable file";
      *detail = entry.name + " (missing, corrupt or not an 8-bit image)";
      return ReadResult::kSkipped;
    }
    if (image.cols != width_ || image.rows != height_) {
      *reason = "frame: wrong size";
      *detail = entry.name + " is " + SizeText(image.cols, image.rows) + ", expected " + SizeText(width_, height_);
      return ReadResult::kSkipped;
    }
    frame->image = image;
    frame->camera = entry.camera;
    frame->has_true_pose = entry.has_pose;
    frame->world_from_camera = entry.world_from_camera;
    frame->name = entry.name;
    frame->recorded_utime = entry.recorded_utime;
    frame->source_index = index;
    frame->rotated_180 = false;
    if (rotate_[static_cast<size_t>(index)]) RotateFrame180(frame);
    return ReadResult::kFrame;
  }

  bool Rewind() override {
    position_ = 0;
    return true;
  }
  int NumFrames() const override { return static_cast<int>(sequence_.size()); }
  SourceKind kind() const override { return kind_; }
  std::string Describe() const override {
    std::ostringstream os;
    os << SourceKindName(kind_) << " " << root_ << ": " << sequence_.size() << " frames of " << entries_.size()
       << " files, " << SizeText(width_, height_);
    if (!note_.empty()) os << ", " << note_;
    return os.str();
  }

 private:
  SourceKind kind_;
  std::string root_;
  std::vector<ListEntry> entries_;
  std::vector<int> sequence_;
  std::vector<bool> rotate_;
  int width_, height_;
  std::string note_;
  size_t position_ = 0;
};

// Resolves --order and --rotate-180 against the natural-order names.
bool ResolveLists(const FrameSourceOptions& options, const std::vector<std::string>& names, std::vector<int>* sequence,
                  std::vector<bool>* rotate, std::string* error) {
  sequence->clear();
  if (Trim(options.order).empty()) {
    for (size_t i = 0; i < names.size(); ++i) sequence->push_back(static_cast<int>(i));
  } else {
    std::string why;
    if (!ParseFrameList(options.order, names, sequence, &why)) return Fail(error, "--order: " + why);
  }
  rotate->assign(names.size(), false);
  if (Lower(Trim(options.rotate_180)) == "all") {
    rotate->assign(names.size(), true);
  } else if (!Trim(options.rotate_180).empty()) {
    std::vector<int> listed;
    std::string why;
    if (!ParseFrameList(options.rotate_180, names, &listed, &why)) return Fail(error, "--rotate-180: " + why);
    for (int i : listed) (*rotate)[static_cast<size_t>(i)] = true;
  }
  return true;
}

// Reads the first decodable images (up to 5) and returns the size of the first one, and whether any of them has
// the expected size (when expected_w > 0).
bool ProbeImageSize(const std::vector<ListEntry>& entries, int expected_w, int expected_h, int* w, int* h,
                    bool* any_matches) {
  int tried = 0;
  bool found = false;
  *any_matches = false;
  for (const auto& entry : entries) {
    if (tried >= 5) break;
    const cv::Mat image = ReadImage8(entry.path);
    if (image.empty()) continue;
    ++tried;
    if (!found) {
      *w = image.cols;
      *h = image.rows;
      found = true;
    }
    if (image.cols == expected_w && image.rows == expected_h) {
      *any_matches = true;
      break;
    }
  }
  return found;
}

std::unique_ptr<FrameSource> OpenImageFolder(const FrameSourceOptions& options, std::string* error) {
  const fs::path root(options.path);
  const fs::path image_dir = fs::is_directory(root / "images") ? root / "images" : root;
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& item : fs::directory_iterator(image_dir, ec)) {
    if (!item.is_regular_file(ec)) continue;
    const std::string name = item.path().filename().string();
    if (IsImageFileName(name)) names.push_back(name);
  }
  if (ec) return Fail(error, "cannot list " + image_dir.string() + ": " + ec.message()), nullptr;
  std::sort(names.begin(), names.end());
  if (names.empty()) {
    int videos = 0;
    for (const auto& item : fs::directory_iterator(root, ec))
      if (IsVideoFileName(item.path().filename().string())) ++videos;
    std::string text = "no images (png jpg jpeg bmp ppm pgm tif) in " + image_dir.string();
    if (videos > 1)
      text += " and " + std::to_string(videos) + " videos (a video folder holds one): give the video as --source";
    return Fail(error, text), nullptr;
  }

  std::string calib_path = options.calib_path;
  if (calib_path.empty()) {
    for (const char* candidate : {"calib.yaml", "calib.yml", "calib.xml", "calib.json"}) {
      if (fs::is_regular_file(root / candidate)) {
        calib_path = (root / candidate).string();
        break;
      }
    }
  }
  if (calib_path.empty()) {
    std::string text = "no calibration: " + (root / "calib.yaml").string() +
                       " not found; pass --calib FILE (OpenCV FileStorage with camera_matrix, "
                       "distortion_coefficients, image_width, image_height)";
    if (fs::exists(root / "dino_Ps_xy.txt") || fs::exists(root / "dino_Ps.mat"))
      text += ". The Oxford dinosaur projection matrices are not a metric calibration and are not used";
    return Fail(error, text), nullptr;
  }
  PinholeCamera camera;
  if (!ReadCalibrationFile(calib_path, options.camera_name, &camera, error)) return nullptr;

  std::vector<ListEntry> entries(names.size());
  for (size_t i = 0; i < names.size(); ++i) {
    entries[i].path = (image_dir / names[i]).string();
    entries[i].name = names[i];
    entries[i].camera = camera;
  }
  int first_w = 0, first_h = 0;
  bool any_matches = false;
  if (!ProbeImageSize(entries, camera.width, camera.height, &first_w, &first_h, &any_matches))
    return Fail(error, "none of the first images in " + image_dir.string() + " can be read"), nullptr;
  if (!any_matches)
    return Fail(error, "calibration " + calib_path + " is for " + SizeText(camera.width, camera.height) +
                           " images but the images in " + image_dir.string() + " are " + SizeText(first_w, first_h)),
           nullptr;

  // Ground truth (evaluation only).
  std::string note = "calibration " + calib_path;
  const fs::path gt_path = root / "poses_gt.txt";
  if (fs::is_regular_file(gt_path)) {
    std::vector<StampedPose> poses;
    if (!ReadTumTrajectory(gt_path.string(), options.gt_position_scale, &poses, error)) return nullptr;
    if (poses.size() == names.size()) {
      for (size_t i = 0; i < names.size(); ++i) {
        entries[i].has_pose = true;
        entries[i].world_from_camera = poses[i].world_from_camera;
      }
      note += ", ground truth by index";
    } else {
      // Match by time: image file names must be timestamps in s (e.g. 1305031102.175304.png).
      size_t matched = 0;
      for (size_t i = 0; i < names.size(); ++i) {
        double t = 0;
        if (!ParseDouble(fs::path(names[i]).stem().string(), &t))
          return Fail(error, gt_path.string() + " has " + std::to_string(poses.size()) + " poses for " +
                                 std::to_string(names.size()) + " images and the image names are not timestamps (" +
                                 names[i] + "): cannot match them"),
                 nullptr;
        double best = 0.02;  // s, largest accepted time difference
        for (const auto& pose : poses) {
          if (std::abs(pose.t - t) <= best) {
            best = std::abs(pose.t - t);
            entries[i].has_pose = true;
            entries[i].world_from_camera = pose.world_from_camera;
          }
        }
        if (entries[i].has_pose) ++matched;
      }
      note += ", ground truth by time for " + std::to_string(matched) + " frames";
    }
  }

  // Image times of a recorded run (common/recorded_run.h), used in the natural order only.
  const fs::path times_path = root / kTimestampsFileName;
  if (fs::is_regular_file(times_path)) {
    if (!options.order.empty()) {
      note += ", " + std::string(kTimestampsFileName) + " not used (--order changes the frame order)";
    } else {
      std::vector<FrameTime> times;
      if (!ReadFrameTimes(times_path.string(), &times, error)) return nullptr;
      std::map<std::string, int64_t> by_name;
      for (const auto& t : times) by_name[t.file_name] = t.utime;
      for (size_t i = 0; i < names.size(); ++i) {
        const auto it = by_name.find(names[i]);
        if (it == by_name.end())
          return Fail(error, times_path.string() + " has no time for " + names[i] + " (every image needs one)"),
                 nullptr;
        if (i > 0 && it->second <= entries[i - 1].recorded_utime)
          return Fail(error, times_path.string() + ": the time of " + names[i] + " does not increase over " +
                                 names[i - 1] + "'s (file-name order is the frame order)"),
                 nullptr;
        entries[i].recorded_utime = it->second;
      }
      note += ", image times from " + std::string(kTimestampsFileName);
    }
  }

  std::vector<int> sequence;
  std::vector<bool> rotate;
  if (!ResolveLists(options, names, &sequence, &rotate, error)) return nullptr;
  return std::make_unique<ListFrameSource>(SourceKind::kImageFolder, image_dir.string(), std::move(entries),
                                           std::move(sequence), std::move(rotate), camera.width, camera.height, note);
}

std::unique_ptr<FrameSource> OpenMiddlebury(const FrameSourceOptions& options, std::string* error) {
  fs::path par_path(options.path);
  if (fs::is_directory(par_path)) {
    std::vector<fs::path> found;
    std::error_code ec;
    for (const auto& item : fs::directory_iterator(par_path, ec)) {
      const std::string name = item.path().filename().string();
      if (name.size() > 8 && name.compare(name.size() - 8, 8, "_par.txt") == 0) found.push_back(item.path());
    }
    if (found.empty()) return Fail(error, "no *_par.txt file in " + par_path.string()), nullptr;
    if (found.size() > 1) {
      std::string text = "several *_par.txt files in " + par_path.string() + ":";
      for (const auto& p : found) text += " " + p.filename().string();
      return Fail(error, text + "; pass --source FOLDER/NAME_par.txt"), nullptr;
    }
    par_path = found[0];
  }
  const fs::path root = par_path.parent_path();
  std::vector<MiddleburyView> views;
  if (!ReadMiddleburyPar(par_path.string(), &views, error)) return nullptr;

  PinholeCamera override_camera;
  const bool has_override = !options.calib_path.empty();
  if (has_override && !ReadCalibrationFile(options.calib_path, options.camera_name, &override_camera, error))
    return nullptr;

  std::vector<ListEntry> entries(views.size());
  std::vector<std::string> names(views.size());
  for (size_t i = 0; i < views.size(); ++i) {
    names[i] = views[i].image_name;
    entries[i].path = (root / views[i].image_name).string();
    entries[i].name = views[i].image_name;
    entries[i].has_pose = true;
    entries[i].world_from_camera = views[i].WorldFromCamera(options.gt_position_scale);
  }
  int width = 0, height = 0;
  bool any_matches = false;
  if (!ProbeImageSize(entries, has_override ? override_camera.width : -1, has_override ? override_camera.height : -1,
                      &width, &height, &any_matches))
    return Fail(error, "none of the first images listed in " + par_path.string() + " can be read"), nullptr;
  if (has_override) {
    if (!any_matches)
      return Fail(error, "calibration " + options.calib_path + " is for " +
                             SizeText(override_camera.width, override_camera.height) + " images but the images are " +
                             SizeText(width, height)),
             nullptr;
    width = override_camera.width;
    height = override_camera.height;
  }
  for (size_t i = 0; i < views.size(); ++i) {
    if (has_override) {
      entries[i].camera = override_camera;
      continue;
    }
    PinholeCamera c;
    c.name = options.camera_name;
    c.width = width;
    c.height = height;
    const Eigen::Matrix3d& k = views[i].K;
    c.fx = k(0, 0);
    c.skew = k(0, 1);
    c.cx = k(0, 2);
    c.fy = k(1, 1);
    c.cy = k(1, 2);
    if (!CheckCamera(c, par_path.string() + " view " + views[i].image_name, error)) return nullptr;
    entries[i].camera = c;
  }
  std::vector<int> sequence;
  std::vector<bool> rotate;
  if (!ResolveLists(options, names, &sequence, &rotate, error)) return nullptr;
  return std::make_unique<ListFrameSource>(
      SourceKind::kMiddlebury, par_path.string(), std::move(entries), std::move(sequence), std::move(rotate), width,
      height, has_override ? "calibration " + options.calib_path : std::string("per-view calibration"));
}

// ---------------------------------------------------------------------------------------------------------------
// Video files and V4L2 devices.

class CaptureFrameSource final : public FrameSource {
 public:
  // frame_times: µs per frame number (a video folder's timestamps.txt); empty: a video's frames get the container's
  // presentation times.
  CaptureFrameSource(SourceKind kind, std::string path, PinholeCamera camera, bool rotate_all,
                     std::vector<int64_t> frame_times, std::string note)
      : kind_(kind),
        path_(std::move(path)),
        camera_(std::move(camera)),
        rotate_all_(rotate_all),
        frame_times_(std::move(frame_times)),
        note_(std::move(note)) {}

  bool Open(int device_width, int device_height, std::string* error) {
    try {
      if (kind_ == SourceKind::kV4l2Device) {
        const bool by_index = IsAllDigits(path_);
        const bool ok =
            by_index ? capture_.open(std::atoi(path_.c_str()), cv::CAP_V4L2) : capture_.open(path_, cv::CAP_V4L2);
        if (!ok || !capture_.isOpened()) return Fail(error, "cannot open V4L2 device " + path_);
        capture_.set(cv::CAP_PROP_FRAME_WIDTH, device_width > 0 ? device_width : camera_.width);
        capture_.set(cv::CAP_PROP_FRAME_HEIGHT, device_height > 0 ? device_height : camera_.height);
        const int w = static_cast<int>(capture_.get(cv::CAP_PROP_FRAME_WIDTH));
        const int h = static_cast<int>(capture_.get(cv::CAP_PROP_FRAME_HEIGHT));
        if (w != camera_.width || h != camera_.height)
          return Fail(error, "device " + path_ + " delivers " + SizeText(w, h) + " but the calibration is for " +
                                 SizeText(camera_.width, camera_.height));
      } else {
        if (!capture_.open(path_) || !capture_.isOpened()) return Fail(error, "cannot open video file " + path_);
      }
      rate_ = capture_.get(cv::CAP_PROP_FPS);
      if (!std::isfinite(rate_) || rate_ < 0 || rate_ > 1000) rate_ = 0;
    } catch (const cv::Exception& e) {
      return Fail(error, "cannot open " + path_ + ": " + e.what());
    }
    return true;
  }

  ReadResult Next(SourceFrame* frame, std::string* reason, std::string* detail) override {
    cv::Mat image;
    bool ok = false;
    try {
      ok = capture_.read(image);
    } catch (const cv::Exception&) {
      ok = false;
    }
    const int index = counter_++;
    if (!ok || image.empty()) {
      if (kind_ == SourceKind::kVideoFile) return ReadResult::kEnd;
      // A live device may drop a frame; give up after a run of failures (unplugged).
      if (++consecutive_failures_ >= 30) return ReadResult::kEnd;
      *reason = "frame: capture failed";
      *detail = path_ + " frame " + std::to_string(index);
      return ReadResult::kSkipped;
    }
    consecutive_failures_ = 0;
    if (image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3)) {
      if (image.channels() == 4 && image.depth() == CV_8U) {
        cv::cvtColor(image, image, cv::COLOR_BGRA2BGR);
      } else {
        *reason = "frame: unsupported pixel format";
        *detail = path_ + " frame " + std::to_string(index);
        return ReadResult::kSkipped;
      }
    }
    if (image.cols != camera_.width || image.rows != camera_.height) {
      *reason = "frame: wrong size";
      *detail = path_ + " frame " + std::to_string(index) + " is " + SizeText(image.cols, image.rows) + ", expected " +
                SizeText(camera_.width, camera_.height);
      return ReadResult::kSkipped;
    }
    frame->image = image;
    frame->camera = camera_;
    frame->has_true_pose = false;
    frame->world_from_camera = Eigen::Isometry3d::Identity();
    frame->name = "frame " + std::to_string(index);
    frame->source_index = index;
    frame->rotated_180 = false;
    frame->recorded_utime = -1;
    if (kind_ == SourceKind::kVideoFile && !FrameTime(index, &frame->recorded_utime, reason, detail))
      return ReadResult::kSkipped;
    if (rotate_all_) RotateFrame180(frame);
    return ReadResult::kFrame;
  }

  bool Rewind() override {
    if (kind_ != SourceKind::kVideoFile) return false;
    capture_.release();
    counter_ = 0;
    last_container_utime_ = -1;
    try {
      return capture_.open(path_) && capture_.isOpened();
    } catch (const cv::Exception&) {
      return false;
    }
  }
  int NumFrames() const override { return -1; }
  double SourceRate() const override { return rate_; }
  bool IsLive() const override { return kind_ == SourceKind::kV4l2Device; }
  SourceKind kind() const override { return kind_; }
  std::string Describe() const override {
    std::ostringstream os;
    os << SourceKindName(kind_) << " " << path_ << ": " << SizeText(camera_.width, camera_.height) << ", " << rate_
       << " fps reported";
    if (kind_ == SourceKind::kVideoFile)
      os << (frame_times_.empty() ? ", frame times from the container" : ", frame times from timestamps.txt");
    os << note_;
    return os.str();
  }

 private:
  // The time of video frame `index` (µs): from the folder's timestamps.txt, else the container's presentation time
  // (must increase; a container without usable times gives index / fps).
  bool FrameTime(int index, int64_t* utime, std::string* reason, std::string* detail) {
    if (!frame_times_.empty()) {
      if (index >= static_cast<int>(frame_times_.size())) {
        *reason = "frame: no time in timestamps.txt";
        *detail = path_ + " frame " + std::to_string(index) + " (timestamps.txt has " +
                  std::to_string(frame_times_.size()) + " frames)";
        return false;
      }
      *utime = frame_times_[index];
      return true;
    }
    double ms = -1;
    try {
      ms = capture_.get(cv::CAP_PROP_POS_MSEC);
    } catch (const cv::Exception&) {
      ms = -1;
    }
    int64_t t = std::isfinite(ms) && ms >= 0 ? std::llround(ms * 1000.0) : -1;
    if (t <= last_container_utime_)  // no usable container time: the nominal one
      t = rate_ > 0 ? std::llround(index * 1e6 / rate_) : -1;
    if (t <= last_container_utime_) t = last_container_utime_ + 1;
    last_container_utime_ = t;
    *utime = t;
    return true;
  }

  SourceKind kind_;
  std::string path_;
  PinholeCamera camera_;
  bool rotate_all_;
  cv::VideoCapture capture_;
  double rate_ = 0;
  int counter_ = 0;
  int consecutive_failures_ = 0;
  std::vector<int64_t> frame_times_;  // µs by frame number (empty: container times)
  std::string note_;
  int64_t last_container_utime_ = -1;
};

// A video folder's timestamps.txt: "FRAME_NUMBER UTIME_US" for the frames 0, 1, 2, ... with increasing times.
bool ReadVideoFrameTimes(const std::string& path, std::vector<int64_t>* times, std::string* error) {
  std::vector<FrameTime> lines;
  if (!ReadFrameTimes(path, &lines, error)) return false;
  std::map<int64_t, int64_t> by_frame;
  for (const FrameTime& t : lines) {
    if (!IsAllDigits(t.file_name) || t.file_name.size() > 9)
      return Fail(error, path + ": '" + t.file_name + "' is not a frame number (a video's timestamps.txt has " +
                             "FRAME_NUMBER UTIME_US lines, frames numbered from 0)");
    by_frame[std::stoll(t.file_name)] = t.utime;
  }
  times->clear();
  for (const auto& [frame, utime] : by_frame) {
    if (frame != static_cast<int64_t>(times->size()))
      return Fail(error, path + " has no time for frame " + std::to_string(times->size()) +
                             " (every frame from 0 on needs one)");
    if (!times->empty() && utime <= times->back())
      return Fail(error, path + ": the time of frame " + std::to_string(frame) + " does not increase");
    times->push_back(utime);
  }
  if (times->empty()) return Fail(error, path + " holds no frame time");
  return true;
}

std::unique_ptr<FrameSource> OpenCapture(SourceKind kind, const FrameSourceOptions& options, std::string* error) {
  if (!Trim(options.order).empty())
    return Fail(error, std::string("--order is not supported for a ") + SourceKindName(kind)), nullptr;
  const std::string rotate = Lower(Trim(options.rotate_180));
  if (!rotate.empty() && rotate != "all")
    return Fail(error, std::string("--rotate-180 takes only 'all' for a ") + SourceKindName(kind)), nullptr;
  // A folder with one video: its calibration, and its timestamps.txt, beside it (common/recorded_run.h).
  std::string video_path = options.path, calib_path = options.calib_path, note;
  std::vector<int64_t> frame_times;
  std::error_code ec;
  if (kind == SourceKind::kVideoFile && fs::is_directory(options.path, ec)) {
    const fs::path root(options.path);
    for (const auto& item : fs::directory_iterator(root, ec))
      if (item.is_regular_file(ec) && IsVideoFileName(item.path().filename().string()))
        video_path = item.path().string();
    if (calib_path.empty())
      for (const char* candidate : {"calib.yaml", "calib.yml", "calib.xml", "calib.json"})
        if (fs::is_regular_file(root / candidate, ec)) {
          calib_path = (root / candidate).string();
          break;
        }
    if (fs::is_regular_file(root / kTimestampsFileName, ec)) {
      if (!ReadVideoFrameTimes((root / kTimestampsFileName).string(), &frame_times, error)) return nullptr;
      note = ", " + std::to_string(frame_times.size()) + " frame times";
    }
  }
  if (calib_path.empty())
    return Fail(error, std::string("a ") + SourceKindName(kind) +
                           " needs --calib FILE (OpenCV FileStorage with "
                           "camera_matrix, distortion_coefficients, "
                           "image_width, image_height)"),
           nullptr;
  PinholeCamera camera;
  if (!ReadCalibrationFile(calib_path, options.camera_name, &camera, error)) return nullptr;
  auto source = std::make_unique<CaptureFrameSource>(kind, video_path, camera, rotate == "all",
                                                     std::move(frame_times), note);
  if (!source->Open(options.device_width, options.device_height, error)) return nullptr;
  return source;
}

}  // namespace

const char* SourceKindName(SourceKind kind) {
  switch (kind) {
    case SourceKind::kImageFolder:
      return "image folder";
    case SourceKind::kMiddlebury:
      return "Middlebury folder";
    case SourceKind::kVideoFile:
      return "video file";
    case SourceKind::kV4l2Device:
      return "V4L2 device";
  }
  return "unknown";
}

bool IsVideoFileName(const std::string& name) {
  const auto dot = name.find_last_of('.');
  if (dot == std::string::npos || dot == 0) return false;
  const std::string ext = Lower(name.substr(dot + 1));
  for (const char* e : {"avi", "mp4", "mkv", "mov", "webm", "m4v", "mpg", "mpeg"})
    if (ext == e) return true;
  return false;
}

bool IsImageFileName(const std::string& name) {
  const auto dot = name.find_last_of('.');
  if (dot == std::string::npos || dot == 0) return false;
  const std::string ext = Lower(name.substr(dot + 1));
  for (const char* e : {"png", "jpg", "jpeg", "bmp", "ppm", "pgm", "tif", "tiff"})
    if (ext == e) return true;
  return false;
}

bool DetectSourceKind(const std::string& path, SourceKind* kind, std::string* error) {
  if (path.empty()) return Fail(error, "no source given (--source PATH)");
  if (IsAllDigits(path) || path.rfind("/dev/video", 0) == 0) {
    *kind = SourceKind::kV4l2Device;
    return true;
  }
  std::error_code ec;
  const fs::path p(path);
  if (fs::is_directory(p, ec)) {
    *kind = SourceKind::kImageFolder;
    int images = 0, videos = 0;
    for (const auto& item : fs::directory_iterator(p, ec)) {
      const std::string name = item.path().filename().string();
      if (name.size() > 8 && name.compare(name.size() - 8, 8, "_par.txt") == 0) {
        *kind = SourceKind::kMiddlebury;
        return true;
      }
      if (IsImageFileName(name)) ++images;
      if (IsVideoFileName(name)) ++videos;
    }
    if (images == 0 && videos == 1 && !fs::is_directory(p / "images", ec)) *kind = SourceKind::kVideoFile;
    return true;
  }
  if (fs::is_regular_file(p, ec)) {
    const std::string name = p.filename().string();
    *kind = name.size() > 8 && name.compare(name.size() - 8, 8, "_par.txt") == 0 ? SourceKind::kMiddlebury
                                                                                 : SourceKind::kVideoFile;
    return true;
  }
  return Fail(error, "source " + path + " does not exist");
}

std::unique_ptr<FrameSource> OpenFrameSource(const FrameSourceOptions& options, std::string* error) {
  if (!(options.gt_position_scale > 0) || !std::isfinite(options.gt_position_scale))
    return Fail(error, "ground-truth position scale must be > 0"), nullptr;
  SourceKind kind;
  if (!DetectSourceKind(options.path, &kind, error)) return nullptr;
  try {
    switch (kind) {
      case SourceKind::kImageFolder:
        return OpenImageFolder(options, error);
      case SourceKind::kMiddlebury:
        return OpenMiddlebury(options, error);
      case SourceKind::kVideoFile:
      case SourceKind::kV4l2Device:
        return OpenCapture(kind, options, error);
    }
  } catch (const std::exception& e) {  // filesystem errors
    return Fail(error, std::string("cannot open ") + options.path + ": " + e.what()), nullptr;
  }
  return nullptr;
}

bool ReadTumTrajectory(const std::string& path, double position_scale, std::vector<StampedPose>* poses,
                       std::string* error) {
  bool units_mm = false;
  if (!ReadTumTrajectory(path, poses, error, &units_mm)) return false;
  // The unit header may come anywhere among the comments: the scale applies to every pose.
  const double scale = units_mm ? 1.0 : position_scale;
  for (auto& pose : *poses) pose.world_from_camera.translation() *= scale;
  return true;
}

Eigen::Isometry3d MiddleburyView::WorldFromCamera(double position_scale) const {
  const Eigen::Matrix3d r = NearestRotation(R);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = r.transpose();
  pose.translation() = -(r.transpose() * t) * position_scale;
  return pose;
}

bool ReadMiddleburyPar(const std::string& path, std::vector<MiddleburyView>* views, std::string* error) {
  std::ifstream in(path);
  if (!in) return Fail(error, "cannot read " + path);
  views->clear();
  std::string line;
  int line_number = 0;
  long expected = -1;
  while (std::getline(in, line)) {
    ++line_number;
    const std::string trimmed = Trim(line);
    if (trimmed.empty()) continue;
    const std::string where = path + ":" + std::to_string(line_number);
    if (expected < 0) {
      double n = 0;
      if (!ParseDouble(trimmed, &n) || n < 1 || n != std::floor(n))
        return Fail(error, where + ": first line must be the number of views");
      expected = static_cast<long>(n);
      continue;
    }
    std::istringstream fields(trimmed);
    MiddleburyView view;
    fields >> view.image_name;
    std::vector<double> v;
    std::string token;
    while (fields >> token) {
      double x = 0;
      if (!ParseDouble(token, &x)) return Fail(error, where + ": bad number '" + token + "'");
      v.push_back(x);
    }
    if (v.size() != 21) return Fail(error, where + ": expected 'name k11..k33 r11..r33 t1 t2 t3' (21 numbers)");
    for (int i = 0; i < 9; ++i) {
      view.K(i / 3, i % 3) = v[static_cast<size_t>(i)];
      view.R(i / 3, i % 3) = v[static_cast<size_t>(9 + i)];
    }
    view.t = Eigen::Vector3d(v[18], v[19], v[20]);
    if (view.K(1, 0) != 0 || view.K(2, 0) != 0 || view.K(2, 1) != 0 || view.K(2, 2) != 1 || !(view.K(0, 0) > 0) ||
        !(view.K(1, 1) > 0))
      return Fail(error, where + ": K must look like [fx s cx; 0 fy cy; 0 0 1] with fx, fy > 0");
    if ((view.R * view.R.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-3 || view.R.determinant() < 0)
      return Fail(error, where + ": R is not a rotation matrix");
    views->push_back(view);
  }
  if (expected < 0) return Fail(error, path + ": empty file");
  if (static_cast<long>(views->size()) != expected)
    return Fail(error,
                path + ": header says " + std::to_string(expected) + " views, found " + std::to_string(views->size()));
  return true;
}

bool ParseFrameList(const std::string& text, const std::vector<std::string>& names, std::vector<int>* indices,
                    std::string* error) {
  indices->clear();
  std::string normalized = text;
  std::replace(normalized.begin(), normalized.end(), ',', ' ');
  std::istringstream tokens(normalized);
  std::string token;
  const int n = static_cast<int>(names.size());
  auto number = [&](const std::string& s, int* out) {
    if (!IsAllDigits(s) || s.size() > 9) return false;
    *out = std::atoi(s.c_str());
    return true;
  };
  while (tokens >> token) {
    int a = 0, b = 0;
    const auto dash = token.find('-');
    if (number(token, &a)) {
      if (a < 1 || a > n) return Fail(error, "frame " + token + " out of range 1.." + std::to_string(n));
      indices->push_back(a - 1);
      continue;
    }
    if (dash != std::string::npos && number(token.substr(0, dash), &a) && number(token.substr(dash + 1), &b)) {
      if (a < 1 || a > n || b < 1 || b > n)
        return Fail(error, "range " + token + " out of range 1.." + std::to_string(n));
      const int step = a <= b ? 1 : -1;
      for (int i = a;; i += step) {
        indices->push_back(i - 1);
        if (i == b) break;
      }
      continue;
    }
    int found = -1;
    for (int i = 0; i < n && found < 0; ++i) {
      const std::string& name = names[static_cast<size_t>(i)];
      if (name == token || fs::path(name).stem().string() == token) found = i;
    }
    if (found < 0) return Fail(error, "no frame named '" + token + "'");
    indices->push_back(found);
  }
  if (indices->empty()) return Fail(error, "empty frame list");
  return true;
}

PinholeCamera RotateCamera180(const PinholeCamera& camera) {
  PinholeCamera c = camera;
  c.cx = camera.width - 1 - camera.cx;
  c.cy = camera.height - 1 - camera.cy;
  c.p1 = -camera.p1;
  c.p2 = -camera.p2;
  return c;
}

Eigen::Isometry3d RotatePose180(const Eigen::Isometry3d& world_from_camera) {
  Eigen::Isometry3d camera_from_rotated = Eigen::Isometry3d::Identity();
  camera_from_rotated.linear() = Eigen::Vector3d(-1, -1, 1).asDiagonal();
  return world_from_camera * camera_from_rotated;
}

void RotateFrame180(SourceFrame* frame) {
  cv::Mat rotated;
  cv::rotate(frame->image, rotated, cv::ROTATE_180);
  frame->image = rotated;
  frame->camera = RotateCamera180(frame->camera);
  if (frame->has_true_pose) frame->world_from_camera = RotatePose180(frame->world_from_camera);
  frame->rotated_180 = !frame->rotated_180;
}

}  // namespace objscan
