#include "common/adapters.h"

#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <unordered_set>

#include "common/geometry.h"

namespace objscan {
namespace {
bool Fail(std::string* error, const char* reason) {
  if (error) *error = reason;
  return false;
}
bool AllFinite(std::initializer_list<double> values) {
  for (double v : values)
    if (!std::isfinite(v)) return false;
  return true;
}
}  // namespace

bool ImageFromMessage(const image_t& msg, ImageFrame* out, std::string* error, int expected_width,
                      int expected_height) {
  if (msg.size != static_cast<int32_t>(msg.data.size())) return Fail(error, "image: truncated data");
  if (msg.width <= 0 || msg.height <= 0 || msg.width > 16384 || msg.height > 16384)
    return Fail(error, "image: bad size");
  if (expected_width > 0 && (msg.width != expected_width || msg.height != expected_height))
    return Fail(error, "image: wrong size");
  cv::Mat image;
  switch (msg.encoding) {
    case image_t::ENCODING_GRAY8:
    case image_t::ENCODING_RGB8:
    case image_t::ENCODING_BGR8: {
      const int channels = msg.encoding == image_t::ENCODING_GRAY8 ? 1 : 3;
      if (msg.stride < msg.width * channels) return Fail(error, "image: bad stride");
      if (static_cast<int64_t>(msg.stride) * msg.height > static_cast<int64_t>(msg.data.size()))
        return Fail(error, "image: truncated data");
      const cv::Mat view(msg.height, msg.width, channels == 1 ? CV_8UC1 : CV_8UC3,
                         const_cast<uint8_t*>(msg.data.data()), static_cast<size_t>(msg.stride));
      if (msg.encoding == image_t::ENCODING_RGB8) cv::cvtColor(view, image, cv::COLOR_RGB2BGR);
      else image = view.clone();
      break;
    }
    case image_t::ENCODING_JPEG: {
      if (msg.data.empty()) return Fail(error, "image: truncated data");
      image = cv::imdecode(msg.data, cv::IMREAD_UNCHANGED);
      if (image.empty()) return Fail(error, "image: undecodable jpeg");
      if (image.cols != msg.width || image.rows != msg.height) return Fail(error, "image: jpeg size mismatch");
      break;
    }
    default:
      return Fail(error, "image: unknown encoding");
  }
  out->utime = msg.utime;
  out->seq = msg.seq;
  out->camera_name = msg.camera_name;
  out->image = image;
  return true;
}

image_t ImageToMessage(const ImageFrame& frame, int8_t encoding, int jpeg_quality) {
  image_t msg;
  msg.utime = frame.utime;
  msg.seq = frame.seq;
  msg.session_id = 0;  // the publishing node stamps its session
  msg.camera_name = frame.camera_name;
  msg.width = frame.image.cols;
  msg.height = frame.image.rows;
  msg.encoding = encoding;
  cv::Mat data;
  if (encoding == image_t::ENCODING_JPEG) {
    cv::imencode(".jpg", frame.image, msg.data, {cv::IMWRITE_JPEG_QUALITY, jpeg_quality});
    msg.stride = 0;
  } else {
    if (encoding == image_t::ENCODING_GRAY8) {
      if (frame.image.channels() == 3) cv::cvtColor(frame.image, data, cv::COLOR_BGR2GRAY);
      else data = frame.image;
    } else if (encoding == image_t::ENCODING_RGB8) {
      if (frame.image.channels() == 1) cv::cvtColor(frame.image, data, cv::COLOR_GRAY2RGB);
      else cv::cvtColor(frame.image, data, cv::COLOR_BGR2RGB);
    } else {
      if (frame.image.channels() == 1) cv::cvtColor(frame.image, data, cv::COLOR_GRAY2BGR);
      else data = frame.image;
    }
    if (!data.isContinuous()) data = data.clone();
    msg.stride = static_cast<int32_t>(data.step[0]);
    msg.data.assign(data.data, data.data + data.total() * data.elemSize());
  }
  msg.size = static_cast<int32_t>(msg.data.size());
  return msg;
}

bool CameraFromMessage(const camera_info_t& msg, PinholeCamera* out, std::string* error) {
  if (msg.num_distortion != static_cast<int32_t>(msg.distortion.size()))
    return Fail(error, "camera_info: array length mismatch");
  PinholeCamera c;
  c.name = msg.camera_name;
  c.width = msg.width;
  c.height = msg.height;
  c.fx = msg.fx;
  c.fy = msg.fy;
  c.cx = msg.cx;
  c.cy = msg.cy;
  c.skew = msg.skew;
  if (msg.distortion_model != "none" && msg.distortion_model != "plumb_bob" && !msg.distortion_model.empty())
    return Fail(error, "camera_info: unknown distortion model");
  double* coeffs[5] = {&c.k1, &c.k2, &c.p1, &c.p2, &c.k3};
  for (size_t i = 0; i < msg.distortion.size() && i < 5; ++i) *coeffs[i] = msg.distortion[i];
  if (!c.IsValid()) return Fail(error, "camera_info: invalid intrinsics");
  *out = c;
  return true;
}

camera_info_t CameraToMessage(const PinholeCamera& c, int64_t utime) {
  camera_info_t msg;
  msg.utime = utime;
  msg.session_id = 0;  // the publishing node stamps its session
  msg.camera_name = c.name;
  msg.width = c.width;
  msg.height = c.height;
  msg.fx = c.fx;
  msg.fy = c.fy;
  msg.cx = c.cx;
  msg.cy = c.cy;
  msg.skew = c.skew;
  msg.distortion_model = c.HasDistortion() ? "plumb_bob" : "none";
  msg.distortion = c.HasDistortion() ? std::vector<double>{c.k1, c.k2, c.p1, c.p2, c.k3} : std::vector<double>{};
  msg.num_distortion = static_cast<int32_t>(msg.distortion.size());
  return msg;
}

bool TracksFromMessage(const feature_tracks_t& msg, TrackFrame* out, std::string* error) {
  const size_t n = static_cast<size_t>(msg.num_tracks < 0 ? 0 : msg.num_tracks);
  if (msg.num_tracks < 0 || msg.track_id.size() != n || msg.u.size() != n || msg.v.size() != n ||
      msg.age.size() != n)
    return Fail(error, "tracks: array length mismatch");
  TrackFrame f;
  f.utime = msg.utime;
  f.seq = msg.seq;
  f.camera_name = msg.camera_name;
  f.width = msg.image_width;
  f.height = msg.image_height;
  f.features.resize(n);
  std::unordered_set<int64_t> ids;
  ids.reserve(n * 2);
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(msg.u[i]) || !std::isfinite(msg.v[i])) return Fail(error, "tracks: non-finite coordinate");
    if (!ids.insert(msg.track_id[i]).second) return Fail(error, "tracks: duplicate id");
    f.features[i] = {msg.track_id[i], msg.u[i], msg.v[i], msg.age[i]};
  }
  *out = std::move(f);
  return true;
}

feature_tracks_t TracksToMessage(const TrackFrame& f) {
  feature_tracks_t msg;
  msg.utime = f.utime;
  msg.seq = f.seq;
  msg.camera_name = f.camera_name;
  msg.image_width = f.width;
  msg.image_height = f.height;
  msg.num_tracks = static_cast<int32_t>(f.features.size());
  for (const auto& t : f.features) {
    msg.track_id.push_back(t.id);
    msg.u.push_back(t.u);
    msg.v.push_back(t.v);
    msg.age.push_back(t.age);
  }
  return msg;
}

bool OdometryFromMessage(const odometry_t& m, OdometryReading* out, std::string* error) {
  if (!AllFinite({m.x_mm, m.y_mm, m.theta_rad, m.pan_rad, m.tilt_rad, m.v_mm_s, m.omega_rad_s, m.pan_rate_rad_s,
                  m.tilt_rate_rad_s}))
    return Fail(error, "odometry: non-finite value");
  *out = {m.utime, m.seq, m.x_mm, m.y_mm, m.theta_rad, m.pan_rad, m.tilt_rad, m.v_mm_s, m.omega_rad_s,
          m.pan_rate_rad_s, m.tilt_rate_rad_s};
  return true;
}

odometry_t OdometryToMessage(const OdometryReading& r) {
  odometry_t m;
  m.utime = r.utime;
  m.seq = r.seq;
  m.session_id = 0;  // the publishing node stamps its session
  m.x_mm = r.x_mm;
  m.y_mm = r.y_mm;
  m.theta_rad = r.theta_rad;
  m.pan_rad = r.pan_rad;
  m.tilt_rad = r.tilt_rad;
  m.v_mm_s = r.v_mm_s;
  m.omega_rad_s = r.omega_rad_s;
  m.pan_rate_rad_s = r.pan_rate_rad_s;
  m.tilt_rate_rad_s = r.tilt_rate_rad_s;
  return m;
}

bool PoseFromMessage(const pose_t& m, CameraPoseEstimate* out, std::string* error) {
  if (!AllFinite({m.position_mm[0], m.position_mm[1], m.position_mm[2], m.orientation[0], m.orientation[1],
                  m.orientation[2], m.orientation[3], m.reprojection_rms_px}))
    return Fail(error, "pose: non-finite value");
  const double qn = std::sqrt(m.orientation[0] * m.orientation[0] + m.orientation[1] * m.orientation[1] +
                              m.orientation[2] * m.orientation[2] + m.orientation[3] * m.orientation[3]);
  if (std::abs(qn - 1.0) > 1e-3) return Fail(error, "pose: quaternion not unit");
  if (m.status < pose_t::STATUS_INITIALIZING || m.status > pose_t::STATUS_GROUND_TRUTH)
    return Fail(error, "pose: unknown status");
  CameraPoseEstimate p;
  p.utime = m.utime;
  p.seq = m.seq;
  p.world_from_camera = PoseFromArrays(m.position_mm, m.orientation);
  p.status = static_cast<PoseStatus>(m.status);
  p.scale_source = static_cast<ScaleSource>(m.scale_source);
  p.num_inliers = m.num_inliers;
  p.reprojection_rms_px = m.reprojection_rms_px;
  p.map_start_seq = m.map_start_seq < 0 ? -1 : m.map_start_seq;
  *out = p;
  return true;
}

pose_t PoseToMessage(const CameraPoseEstimate& p, const std::string& parent_frame, const std::string& child_frame) {
  pose_t m;
  m.utime = p.utime;
  m.seq = p.seq;
  m.parent_frame = parent_frame;
  m.child_frame = child_frame;
  PoseToArrays(p.world_from_camera, m.position_mm, m.orientation);
  m.status = static_cast<int8_t>(p.status);
  m.scale_source = static_cast<int8_t>(p.scale_source);
  m.num_inliers = p.num_inliers;
  m.reprojection_rms_px = p.reprojection_rms_px;
  m.map_start_seq = p.map_start_seq;
  return m;
}

}  // namespace objscan
