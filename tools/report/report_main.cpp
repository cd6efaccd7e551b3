// objscan_report: writes DIR/report.html for a run folder (tools/report/report.h says what is in it).
//   objscan_report DIR [--pictures-dir D] [--figures CAPTION=FILE]...
//       D: PNGs to show as the model's pictures (file name = caption); FILE: "key value" lines (objscan_evaluate's).
//   objscan_report views DIR
//       prints one line per picture to render: NAME, then the viewer options that look at the model from that side
//       (the model's centre and size from model_mesh.ply, else model_voxels.ply); nothing when there is no model.
// Exit status: 0 written; 1 DIR holds none of the run's files, or report.html cannot be written; 2 usage.
#include <dirent.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "tools/report/report.h"
#include "tools/report/report_log.h"

namespace {

using objscan::StampedPose;

bool Exists(const std::string& path) { return std::ifstream(path).good(); }

std::string ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

int Usage(const std::string& why) {
  std::fprintf(stderr,
               "error: %s\nusage: objscan_report DIR [--pictures-dir D] [--figures CAPTION=FILE]...\n"
               "       objscan_report views DIR\n",
               why.c_str());
  return 2;
}

// Model centre (per-axis median) and radius (90th percentile distance from it), mm.
bool ModelExtent(const std::string& dir, Eigen::Vector3d* centre, double* radius) {
  std::vector<Eigen::Vector3d> points;
  std::string error;
  for (const char* name : {"model_mesh.ply", "model_voxels.ply"})
    if (Exists(dir + "/" + name) && objscan::ReadPlyPoints(dir + "/" + name, &points, &error) && !points.empty())
      break;
  if (points.empty()) return false;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> v;
    for (const auto& p : points) v.push_back(p[axis]);
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    (*centre)[axis] = v[v.size() / 2];
  }
  std::vector<double> d;
  for (const auto& p : points) d.push_back((p - *centre).norm());
  std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() * 9 / 10), d.end());
  *radius = std::max(10.0, d[d.size() * 9 / 10]);
  return true;
}

int Views(const std::string& dir) {
  Eigen::Vector3d c;
  double radius = 0;
  if (!ModelExtent(dir, &c, &radius)) return 0;
  struct View {
    const char* name;
    double yaw_deg, pitch_deg;
  };
  // The viewer's field of view is 50 deg: at 3 radii the model fills about 70 % of the picture's height.
  for (const View& v : {View{"model from +x", 0, 25}, View{"model from +y", 90, 25}, View{"model from -x", 180, 25},
                        View{"model from -y", 270, 25}, View{"model from above", 0, 85}})
    std::printf("%s|--view %g,%g,%.1f,%.1f,%.1f,%.1f\n",  // yaw, pitch, distance, target
                v.name, v.yaw_deg, v.pitch_deg, 3 * radius, c.x(), c.y(), c.z());
  return 0;
}

std::string SummaryStatus(const std::string& json) {
  const auto k = json.find("\"status\"");
  if (k == std::string::npos) return "";
  const auto q1 = json.find('"', json.find(':', k) + 1);
  const auto q2 = q1 == std::string::npos ? q1 : json.find('"', q1 + 1);
  return q2 == std::string::npos ? "" : json.substr(q1 + 1, q2 - q1 - 1);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 2 && (std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h")) {
    std::printf("usage: objscan_report DIR [--pictures-dir D] [--figures CAPTION=FILE]...\n"
                "       objscan_report views DIR\n");
    return 0;
  }
  if (argc >= 2 && std::string(argv[1]) == "views") {
    if (argc != 3) return Usage("views takes DIR");
    return Views(argv[2]);
  }
  if (argc < 2 || std::string(argv[1]).rfind("-", 0) == 0) return Usage("give the run folder DIR");
  const std::string dir = argv[1];
  objscan::ReportInputs in;
  std::string pictures_dir;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) return Usage(a + " needs a value");
    const std::string value = argv[++i];
    if (a == "--pictures-dir") {
      pictures_dir = value;
    } else if (a == "--figures") {
      const auto eq = value.find('=');
      if (eq == std::string::npos || eq == 0) return Usage("--figures wants CAPTION=FILE, got '" + value + "'");
      std::ifstream f(value.substr(eq + 1));
      if (!f) return Usage("cannot read " + value.substr(eq + 1));
      std::vector<std::pair<std::string, std::string>> lines;
      std::string key, val;
      while (f >> key >> val) lines.push_back({key, val});
      in.figures.push_back({value.substr(0, eq), lines});
    } else {
      return Usage("unknown option '" + a + "'");
    }
  }
  in.title = dir;
  std::string error;
  int found = 0;
  auto trajectory = [&](const std::string& name, std::vector<StampedPose>* poses) {
    const std::string path = dir + "/" + name;
    if (!Exists(path)) {
      in.missing.push_back(name);
      return;
    }
    if (!objscan::ReadTumTrajectory(path, poses, &error)) {
      std::fprintf(stderr, "warning: %s: %s\n", path.c_str(), error.c_str());
      in.missing.push_back(name + " (unreadable: " + error + ")");
      return;
    }
    std::sort(poses->begin(), poses->end(), [](const StampedPose& a, const StampedPose& b) { return a.t < b.t; });
    ++found;
  };
  trajectory("trajectory.txt", &in.final_poses);
  trajectory("trajectory_online.txt", &in.online_poses);
  if (Exists(dir + "/ground_truth/poses_gt.txt")) {
    trajectory("ground_truth/poses_gt.txt", &in.truth);
    in.truth_source = "ground_truth/poses_gt.txt";
  }
  if (Exists(dir + "/summary.json")) {
    in.summary_json = ReadText(dir + "/summary.json");
    in.status = SummaryStatus(in.summary_json);
    ++found;
  } else {
    in.missing.push_back("summary.json");
  }
  const std::string log = dir + "/session.lcmlog";
  if (Exists(log)) {
    std::string damage;
    std::vector<StampedPose> logged_truth;
    if (!objscan::ReadFrameSeries(log, &in.frames, &logged_truth, &damage, &error)) {
      in.missing.push_back("session.lcmlog (unreadable: " + error + ")");
    } else {
      ++found;
      if (!damage.empty()) in.missing.push_back("part of session.lcmlog (damaged: " + damage + ")");
      // No ground_truth/ folder (not the simulator): the true poses the driver published, e.g. a dataset's
      // calibrated views.
      if (in.truth.empty() && logged_truth.size() >= 3) {
        std::sort(logged_truth.begin(), logged_truth.end(),
                  [](const StampedPose& a, const StampedPose& b) { return a.t < b.t; });
        in.truth = std::move(logged_truth);
        in.truth_source = "GROUND_TRUTH_POSE in session.lcmlog";
      }
    }
  } else {
    in.missing.push_back("session.lcmlog");
  }
  if (found == 0) {
    std::fprintf(stderr, "error: %s holds no trajectory, summary.json or session.lcmlog: is it a run folder?\n",
                 dir.c_str());
    return 1;
  }
  if (!pictures_dir.empty()) {
    std::vector<std::string> names;
    if (DIR* d = opendir(pictures_dir.c_str())) {
      while (dirent* e = readdir(d)) {
        const std::string n = e->d_name;
        if (n.size() > 4 && n.substr(n.size() - 4) == ".png") names.push_back(n);
      }
      closedir(d);
    }
    std::sort(names.begin(), names.end());
    for (const auto& n : names) {
      const std::string bytes = ReadText(pictures_dir + "/" + n);
      std::string caption = n.substr(0, n.size() - 4);
      const auto sep = caption.find('_');  // "1_model from +x" -> "model from +x"
      if (sep != std::string::npos && sep < 3) caption = caption.substr(sep + 1);
      in.pictures.push_back({caption, std::vector<uint8_t>(bytes.begin(), bytes.end())});
    }
  }
  const std::string html = objscan::RenderReportHtml(in);
  const std::string out = dir + "/report.html", partial = out + ".partial";
  {
    std::ofstream f(partial, std::ios::binary);
    f << html;
    if (!f.good()) {
      std::fprintf(stderr, "error: cannot write %s\n", partial.c_str());
      return 1;
    }
  }
  if (std::rename(partial.c_str(), out.c_str()) != 0) {
    std::fprintf(stderr, "error: cannot write %s\n", out.c_str());
    return 1;
  }
  std::printf("%s (%zu kB, %zu pictures)\n", out.c_str(), html.size() / 1024, in.pictures.size());
  return 0;
}
