// objscan_probe: looks at the first frames of an image source and says how to track it (KLT or descriptor
// tracking, see processes/tracker/tracking_mode.h). `objscan run --dataset` calls it before it starts the processes.
// Output (stdout), one item per line: "tracking klt" or "tracking wide"; for a wide-baseline set without --order
// whose views are better chained in another order (OrderViewsByOverlap: up to 200 frames), "order LIST" (1-based
// positions in the natural order, for the camera driver's --order); "# " lines carry the figures. Exit 0 on a
// verdict; 1 when the source cannot be opened or holds fewer than 2 readable frames (the message says which).
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "common/options.h"
#include "drivers/camera/frame_source.h"
#include "processes/tracker/tracking_mode.h"

int main(int argc, char** argv) {
  using namespace objscan;
  FrameSourceOptions source;
  constexpr int frames = 6;  // frames looked at from the start (no flag since issue 27)
  static_assert(frames >= 2, "the mode is measured between frames");
  OptionParser parser("objscan_probe",
                      "Measures how far apart the first frames of an image source are and prints the tracking mode "
                      "to use: 'tracking klt' (video rate) or 'tracking wide' (descriptor tracking).");
  parser.Add("source", &source.path, "image folder, Middlebury folder or video file (as the camera driver takes it)");
  parser.Add("calib", &source.calib_path, "calibration file overriding the source's own (as the camera driver)");
  parser.Add("order", &source.order, "frame order (as the camera driver's --order)");
  parser.Add("rotate-180", &source.rotate_180, "frames to rotate by 180 deg (as the camera driver)");
  int exit_code = 0;
  if (!ParseCommandLineOrExit(parser, argc, argv, &exit_code)) return exit_code;
  std::string error;
  std::unique_ptr<FrameSource> src = OpenFrameSource(source, &error);
  if (!src) {
    std::fprintf(stderr, "objscan_probe: %s\n", error.c_str());
    return 1;
  }
  // The first frames decide the mode; a wide-baseline set without a given order is then read whole to order it.
  constexpr int kMaxOrderedFrames = 200;
  std::vector<cv::Mat> images;
  std::vector<int> natural_index;  // 0-based position of each image in the natural order
  auto read = [&](int count) {     // appends up to count readable frames (unreadable ones are skipped)
    SourceFrame frame;
    std::string reason, detail;
    for (int wanted = static_cast<int>(images.size()) + count; static_cast<int>(images.size()) < wanted;) {
      const ReadResult r = src->Next(&frame, &reason, &detail);
      if (r == ReadResult::kEnd) return;
      if (r != ReadResult::kFrame) continue;
      images.push_back(frame.image.clone());
      natural_index.push_back(frame.source_index);
    }
  };
  read(frames);
  if (images.size() < 2) {
    std::fprintf(stderr, "objscan_probe: %s holds fewer than 2 readable frames\n", source.path.c_str());
    return 1;
  }
  const TrackingModeProbe probe = ProbeTrackingMode(images);
  std::printf("tracking %s\n", probe.wide_baseline ? "wide" : "klt");
  std::printf("# %s\n", probe.detail.c_str());
  if (probe.wide_baseline && source.order.empty() && src->NumFrames() >= 0 && src->NumFrames() <= kMaxOrderedFrames) {
    read(kMaxOrderedFrames);
    const ViewOrder order = OrderViewsByOverlap(images);
    if (order.reordered) {
      std::string list;
      for (int i : order.order) list += (list.empty() ? "" : ",") + std::to_string(natural_index[i] + 1);
      std::printf("order %s\n", list.c_str());
    }
    std::printf("# %s\n", order.detail.c_str());
  }
  return 0;
}
