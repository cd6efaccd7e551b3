// objscan_export: dataset export and COLMAP conversion.
//   objscan_export --log SESSION.lcmlog --out DIR [--every N] [--max-frames N] [--channel CAMERA_IMAGE=NAME] ...
//       LCM log -> dataset folder (images/NNNNNN.png, calib.yaml, timestamps.txt, poses_gt.txt, odometry.txt,
//       robot.cfg with --robot-file), readable by the
//       camera driver (--source DIR). Prints a summary as "key value" lines on stdout.
//   objscan_export colmap-to-tum IMAGES.txt OUT.txt [--rate 30]
//       COLMAP images.txt (cam_from_world) -> TUM camera-to-world, t = frame number in the image name / rate.
//   objscan_export colmap-camera CALIB.yaml
//       prints "MODEL PARAMS" for COLMAP's --ImageReader.camera_model / --ImageReader.camera_params.
// Exit status: 0 ok, 1 failure, 2 bad command line.
#include <cstdio>
#include <string>
#include <vector>

#include "common/log.h"
#include "common/options.h"
#include "tools/export/colmap_convert.h"
#include "tools/export/export_dataset.h"
#include "tools/export/log_export.h"

namespace {
using namespace objscan;

int Fail(const std::string& message) {
  LogError(message);
  return 1;
}

int ColmapToTum(int argc, char** argv) {
  double rate = 30;
  OptionParser parser("objscan_export colmap-to-tum IMAGES.txt OUT.txt",
                      "Converts COLMAP images.txt to a TUM camera-to-world trajectory (t = frame number / rate).");
  parser.Add("rate", &rate, "Hz, frame rate: image NNNNNN gets t = NNNNNN / rate s");
  int code = 0;
  if (!ParseCommandLineOrExit(parser, argc, argv, &code, true)) return code;
  if (parser.positional().size() != 2 || !(rate > 0)) {
    std::fprintf(stderr, "%s", parser.Usage().c_str());
    return 2;
  }
  std::vector<ColmapImage> images;
  std::vector<StampedPose> poses;
  std::string error;
  if (!ReadColmapImagesTxt(parser.positional()[0], &images, &error)) return Fail(error);
  if (!ColmapImagesToTum(images, rate, &poses, &error)) return Fail(error);
  if (!WriteTumTrajectory(parser.positional()[1], poses,
                     {"COLMAP reconstruction " + parser.positional()[0] +
                          ": world_from_camera in model units "
                          "(arbitrary scale), t = frame number / " +
                          std::to_string(rate) + " Hz",
                      "t tx ty tz qx qy qz qw"},
                     &error, -1))  // lossless: model units can be small
    return Fail(error);
  std::printf("images %zu\n", images.size());
  return 0;
}

int ColmapCamera(int argc, char** argv) {
  OptionParser parser("objscan_export colmap-camera CALIB.yaml",
                      "Prints the COLMAP camera model and parameters of an objscan calibration file.");
  int code = 0;
  if (!ParseCommandLineOrExit(parser, argc, argv, &code, true)) return code;
  if (parser.positional().size() != 1) {
    std::fprintf(stderr, "%s", parser.Usage().c_str());
    return 2;
  }
  PinholeCamera camera;
  std::string model, params, error;
  if (!ReadCalibrationFile(parser.positional()[0], "camera", &camera, &error)) return Fail(error);
  if (!ColmapCameraFromCalibration(camera, &model, &params, &error)) return Fail(error);
  std::printf("%s %s\n", model.c_str(), params.c_str());
  return 0;
}

int ExportLog(int argc, char** argv) {
  LogExportOptions options;
  OptionParser parser("objscan_export",
                      "Exports an objscan LCM log to a dataset folder (images/NNNNNN.png, calib.yaml, poses_gt.txt, "
                      "odometry.txt).\nOther commands: objscan_export colmap-to-tum IMAGES.txt OUT.txt [--rate R]; "
                      "objscan_export colmap-camera CALIB.yaml");
  AddLogExportOptions(parser, &options);
  int code = 0;
  if (!ParseCommandLineOrExit(parser, argc, argv, &code, true)) return code;
  std::string error;
  if (!parser.positional().empty()) error = "unexpected argument " + parser.positional()[0];
  if (error.empty()) ValidateLogExportOptions(options, &error);
  if (!error.empty()) {
    std::fprintf(stderr, "error: %s\n%s", error.c_str(), parser.Usage().c_str());
    return 2;
  }
  std::fprintf(stderr, "%s", parser.Effective().c_str());
  LogExportResult result;
  if (!ExportLogToDataset(options, &result, &error)) return Fail(error);
  const DatasetExportSummary& s = result.dataset;
  std::printf(
      "events_read %lld\nframes_written %lld\nframes_not_selected %lld\nframes_undecodable %lld\n"
      "frames_duplicate_seq %lld\nframes_out_of_order %lld\nframes_size_mismatch %lld\ncalibration %s\n"
      "calibration_changes %lld\n"
      "true_poses_written %lld\nframes_without_true_pose %lld\nodometry_written %lld\nodometry_repeated_time %lld\n",
      static_cast<long long>(result.events_read), static_cast<long long>(s.frames_written),
      static_cast<long long>(s.frames_not_selected), static_cast<long long>(s.frames_undecodable),
      static_cast<long long>(s.frames_duplicate_seq), static_cast<long long>(s.frames_out_of_order),
      static_cast<long long>(s.frames_size_mismatch),
      s.has_calibration ? "yes" : "no", static_cast<long long>(s.calibration_changes),
      static_cast<long long>(s.true_poses_written), static_cast<long long>(s.frames_without_true_pose),
      static_cast<long long>(s.odometry_written), static_cast<long long>(s.odometry_repeated_time));
  for (const auto& [reason, count] : result.rejected)
    std::printf("rejected \"%s\" %lld\n", reason.c_str(), static_cast<long long>(count));
  if (!s.has_calibration) LogWarning("no camera_info_t on " + options.info_channel + ": calib.yaml not written");
  if (s.frames_size_mismatch > 0) LogWarning("some frames differ in size from the calibration");
  if (s.calibration_changes > 0) LogWarning("the calibration changes over the log: calib.yaml holds the first one");
  if (s.frames_without_true_pose > 0)
    LogWarning("some frames have no true pose: poses_gt.txt has fewer lines than images/ has files");
  if (s.frames_written == 0) return Fail("no frame written");
  if (!result.log_damage.empty()) {
    LogError("the log is damaged: " + result.log_damage + "; the folder holds the frames that could be read (exit 3)");
    return 3;
  }
  return 0;
}
}  // namespace

int main(int argc, char** argv) {
  objscan::SetLogName("objscan_export");
  const std::string command = argc > 1 ? argv[1] : "";
  if (command == "colmap-to-tum") return ColmapToTum(argc - 1, argv + 1);
  if (command == "colmap-camera") return ColmapCamera(argc - 1, argv + 1);
  return ExportLog(argc, argv);
}
