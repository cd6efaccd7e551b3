#include "processes/pose_solver/output.h"

#include "common/ply.h"
#include "common/tum.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <unordered_map>

namespace objscan {

namespace {
bool Fail(std::string* error, const std::string& reason) {
  if (error) *error = reason;
  return false;
}
}  // namespace

bool IsWrittenPose(PoseStatus s) { return s == PoseStatus::kTracking || s == PoseStatus::kRelocalized; }

bool WriteTumTrajectory(const std::string& path, const std::vector<CameraPoseEstimate>& poses, std::string* error,
                        bool include_all_statuses) {
  // The scale of the poses written (the last one's: a map's scale source only improves, none -> metric).
  ScaleSource scale = ScaleSource::kNone;
  std::vector<StampedPose> written;
  for (const auto& p : poses) {
    if (!include_all_statuses && !IsWrittenPose(p.status)) continue;
    scale = p.scale_source;
    StampedPose s;
    s.t = p.utime / 1e6;
    s.world_from_camera = p.world_from_camera;
    written.push_back(s);
  }
  const std::vector<std::string> header = {
      std::string("TUM trajectory: timestamp[s] tx ty tz qx qy qz qw; camera-to-world (world_from_camera); positions "
                  "in ") + (IsMetric(scale) ? "mm" : "an arbitrary unit"),
      std::string("scale: ") + ScaleDescription(scale)};
  std::string why;
  if (!objscan::WriteTumTrajectory(path, written, header, &why, 4)) return Fail(error, why);
  return true;
}

bool WriteLandmarksPly(const std::string& path, const std::vector<Landmark>& landmarks, ScaleSource scale,
                       std::string* error) {
  PlyLayout layout;
  layout.binary = false;
  layout.ascii_float_format = "%.3f";
  layout.comments = {std::string("objscan pose_solver landmarks, world frame, ") +
                         (IsMetric(scale) ? "mm" : "arbitrary unit"),
                     std::string("scale: ") + ScaleDescription(scale)};
  layout.vertex_properties = PlyXyz();
  for (const char* c : {"red", "green", "blue"}) layout.vertex_properties.push_back({c, PlyScalar::kUChar});
  layout.vertex_properties.push_back({"nobs", PlyScalar::kInt});
  layout.vertex_properties.push_back({"error", PlyScalar::kFloat});
  std::string why;
  const bool ok = WritePlyFile(
      path, layout, landmarks.size(),
      [&](size_t i, double* row) {
        const Landmark& l = landmarks[i];
        for (int k = 0; k < 3; ++k) row[k] = l.position_mm[k];
        row[3] = row[4] = row[5] = 200;
        row[6] = l.num_observations;
        row[7] = l.reprojection_rms_px;
      },
      nullptr, &why);
  return ok ? true : Fail(error, why);
}

bool WriteColmapText(const std::string& dir, const PinholeCamera& camera, const std::vector<ColmapImage>& images,
                     const std::vector<Landmark>& landmarks, std::string* error) {
  size_t next = 0;
  return WriteColmapText(
      dir, camera,
      [&](ColmapImage* image) {
        if (next >= images.size()) return false;
        *image = images[next++];
        return true;
      },
      landmarks, error);
}

bool WriteColmapText(const std::string& dir, const PinholeCamera& camera,
                     const std::function<bool(ColmapImage*)>& next_image, const std::vector<Landmark>& landmarks,
                     std::string* error) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return Fail(error, "cannot create " + dir + ": " + ec.message());
  {
    std::ofstream out(dir + "/cameras.txt");
    if (!out) return Fail(error, "cannot write " + dir + "/cameras.txt");
    out << "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
           "# Number of cameras: 1\n";
    out << std::setprecision(12);
    if (camera.HasDistortion())
      out << "1 OPENCV " << camera.width << ' ' << camera.height << ' ' << camera.fx << ' ' << camera.fy << ' '
          << camera.cx << ' ' << camera.cy << ' ' << camera.k1 << ' ' << camera.k2 << ' ' << camera.p1 << ' '
          << camera.p2 << '\n';
    else
      out << "1 PINHOLE " << camera.width << ' ' << camera.height << ' ' << camera.fx << ' ' << camera.fy << ' '
          << camera.cx << ' ' << camera.cy << '\n';
    if (!out) return Fail(error, "write error on cameras.txt");
  }
  std::unordered_map<int64_t, size_t> landmark_index;
  for (size_t i = 0; i < landmarks.size(); ++i) landmark_index[landmarks[i].id] = i;
  std::vector<std::vector<std::pair<int, int>>> tracks(landmarks.size());
  {
    std::ofstream out(dir + "/images.txt");
    if (!out) return Fail(error, "cannot write " + dir + "/images.txt");
    out << "# Image list with two lines of data per image:\n"
           "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
           "#   POINTS2D[] as (X, Y, POINT3D_ID)\n# Units: mm; pose is cam_from_world\n";
    out << std::setprecision(12);
    int image_id = 0;
    ColmapImage im;
    while (next_image(&im)) {
      if (!IsWrittenPose(im.pose.status)) continue;
      ++image_id;
      const Eigen::Isometry3d cw = im.pose.world_from_camera.inverse();
      const Eigen::Quaterniond q(cw.linear());
      const Eigen::Vector3d t = cw.translation();
      out << image_id << ' ' << q.w() << ' ' << q.x() << ' ' << q.y() << ' ' << q.z() << ' ' << t.x() << ' ' << t.y()
          << ' ' << t.z() << " 1 " << im.name << '\n';
      int idx = 0;
      for (const auto& f : im.features) {
        auto it = landmark_index.find(f.id);
        const int64_t pid = it == landmark_index.end() ? -1 : f.id;
        if (idx > 0) out << ' ';
        out << f.u << ' ' << f.v << ' ' << pid;
        if (it != landmark_index.end()) tracks[it->second].push_back({image_id, idx});
        ++idx;
      }
      out << '\n';
    }
    if (!out) return Fail(error, "write error on images.txt");
  }
  {
    std::ofstream out(dir + "/points3D.txt");
    if (!out) return Fail(error, "cannot write " + dir + "/points3D.txt");
    out << "# 3D point list with one line of data per point:\n"
           "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n# Units: mm\n";
    out << std::setprecision(10);
    for (size_t i = 0; i < landmarks.size(); ++i) {
      const Landmark& l = landmarks[i];
      out << l.id << ' ' << l.position_mm.x() << ' ' << l.position_mm.y() << ' ' << l.position_mm.z() << " 200 200 200 "
          << l.reprojection_rms_px;
      for (const auto& [im, idx] : tracks[i]) out << ' ' << im << ' ' << idx;
      out << '\n';
    }
    if (!out) return Fail(error, "write error on points3D.txt");
  }
  return true;
}

ObservationSpool::ObservationSpool(const std::string& path) : path_(path) {
  file_ = std::fopen(path.c_str(), "w+b");
  ok_ = file_ != nullptr;
  if (!ok_) error_ = "cannot create " + path;
}

ObservationSpool::~ObservationSpool() {
  if (file_) std::fclose(file_);
  if (!path_.empty()) std::remove(path_.c_str());
}

// Record: int64 seq, int64 count, then count x (int64 id, float u, float v), native byte order (the file never
// leaves the process that wrote it).
bool ObservationSpool::Append(const TrackFrame& frame) {
  if (!ok_) return false;
  const int64_t head[2] = {frame.seq, static_cast<int64_t>(frame.features.size())};
  bool good = std::fwrite(head, sizeof(head), 1, file_) == 1;
  for (const TrackedFeature& f : frame.features) {
    if (!good) break;
    good = std::fwrite(&f.id, sizeof(f.id), 1, file_) == 1 && std::fwrite(&f.u, sizeof(f.u), 1, file_) == 1 &&
           std::fwrite(&f.v, sizeof(f.v), 1, file_) == 1;
  }
  if (!good) {
    ok_ = false;
    error_ = "write error on " + path_;
    return false;
  }
  ++frames_;
  return true;
}

bool ObservationSpool::Rewind() {
  if (!ok_) return false;
  if (std::fflush(file_) != 0 || std::fseek(file_, 0, SEEK_SET) != 0) {
    ok_ = false;
    error_ = "cannot rewind " + path_;
    return false;
  }
  return true;
}

bool ObservationSpool::Next(int64_t* seq, std::vector<TrackedFeature>* features) {
  if (!ok_) return false;
  int64_t head[2];
  if (std::fread(head, sizeof(head), 1, file_) != 1) return false;  // end of the file
  if (head[1] < 0 || head[1] > (int64_t{1} << 24)) {
    ok_ = false;
    error_ = "corrupt record in " + path_;
    return false;
  }
  *seq = head[0];
  features->assign(static_cast<size_t>(head[1]), TrackedFeature());
  for (TrackedFeature& f : *features) {
    if (std::fread(&f.id, sizeof(f.id), 1, file_) != 1 || std::fread(&f.u, sizeof(f.u), 1, file_) != 1 ||
        std::fread(&f.v, sizeof(f.v), 1, file_) != 1) {
      ok_ = false;
      error_ = "truncated record in " + path_;
      return false;
    }
  }
  return true;
}

}  // namespace objscan
