// ViewerApp: the "viewer" process. A GLFW window with the 3-D scene (SceneRenderer) and Dear ImGui panels
// (playback, layers, camera image with tracks, channel table, process status table), fed either from a live LCM bus
// (every channel is subscribed; MessageDispatcher decodes the known ones) or from a log file read directly
// (LogPlayer: play / pause / step / seek / speed).
// Headless use: --screenshot FILE.png renders once the chosen log time / message count / end of log is reached,
// writes the window (scene + panels) as PNG and returns. --benchmark ball:N / scatter:N renders a synthetic N-voxel
// model (--benchmark log --log FILE: the scene at the end of the log) while orbiting the view, for 5 s (or
// MODEL@SECONDS), and prints frames/s and CPU time per frame.
// Needs an X display (Xvfb works, with Mesa llvmpipe). Run() does not throw; it returns the process exit code.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "viewer/scene_renderer.h"
#include "viewer/view_camera.h"
#include "viewer/viewer_state.h"

namespace objscan {

class OptionParser;

struct ViewerOptions {
  std::string name = "viewer";                    // process name (status name, log prefix)
  std::string lcm_url;                            // live LCM URL ("" = the objscan default); ignored with log
  std::string log;                                // LCM log file to play instead of a live bus
  ViewerChannels channels;                        // channels decoded (others are listed as unknown)
  std::string status_channel = "PROCESS_STATUS";  // where the viewer publishes its own status (live only)
  int window_width = 1280;                        // px, window width
  int window_height = 800;                        // px, window height
  int panel_width = 500;                          // px, right-hand panel column (0 = no panels)
  bool vsync = true;                              // wait for vertical sync (interactive use)
  bool align_truth = true;                        // draw the truth in the estimate's frame (Sim(3) fit), errors too
  std::string view = "iso";                       // PRESET or YAW,PITCH[,DISTANCE[,X,Y,Z[,FOV]]] (ParseViewSpec)
  bool follow = false;                         // start in follow-camera mode (target tracks the newest pose)
  double speed = 1.0;                          // log playback speed (> 0)
  bool paused = false;                         // start the log paused
  std::string screenshot;                      // PNG path: take a screenshot and exit
  int64_t screenshot_at_utime = -1;            // µs, log time to take the screenshot at (-1 = unused)
  int64_t screenshot_after_messages = -1;      // take it after this many messages (-1 = unused)
  double screenshot_timeout_s = 30.0;          // s, live only: take it anyway after this wall time
  std::string benchmark;                       // "" = none; else MODEL[@SECONDS] (ParseBenchmarkSpec)
  int min_votes = 0;                           // initial voxel display threshold (votes)
  bool cull_hidden_voxels = true;              // skip voxel faces hidden by neighbours
  std::string voxel_style = "auto";            // voxels as cubes, points, or auto (points above max_cube_instances)
  int64_t max_cube_instances = 100000;         // auto style: most visible voxels drawn as cubes
  int64_t max_mesh_faces = 300000;             // exposed voxel faces drawn as one static mesh at most (else instanced)
  double voxel_lod_px = 1.0;                   // px, merged level-of-detail cells project at most this wide (0 = off)
  double voxel_points_px = 3.0;                // px, auto style: points while voxels project at most this wide
  int64_t voxel_occlusion_min_points = 20000;  // points path: CPU depth pass from this many points (0 = off)
  std::string landmark_coloring = "error";     // landmark colours: error, age or rgb
  double max_reprojection_error_px = 3.0;      // px, reprojection error drawn full red (> 0)
  int max_events_per_frame = 20000;            // messages handled per rendered frame at most (>= 1)
};

// Registers the options a user sets on the command line (the rest keep their defaults; code and tests set the
// struct's fields directly).
void AddViewerOptions(OptionParser& parser, ViewerOptions* options);
bool ValidateViewerOptions(const ViewerOptions& options, std::string* why);

// The --benchmark option: MODEL[@SECONDS]. MODEL is "log" (the scene at the end of --log) or "ball:N" / "scatter:N"
// (a synthetic model of N voxels: a solid ball, or voxels none of which touches another); SECONDS (> 0, default 5)
// is how long the view orbits. False with *why set for a bad spec.
struct BenchmarkSpec {
  std::string model;     // "log", "ball" or "scatter"
  int voxels = 0;        // ball / scatter: voxels of the synthetic model (> 0)
  double seconds = 5.0;  // s, benchmark duration
};
bool ParseBenchmarkSpec(const std::string& spec, BenchmarkSpec* benchmark, std::string* why);

// The view camera the options describe (--view; the default view when it is invalid).
OrbitView InitialView(const ViewerOptions& options);
// The scene viewport for a framebuffer: the left part, right of it the panel column.
Viewport SceneViewport(int framebuffer_width, int framebuffer_height, int panel_width);

// Runs the viewer until the window is closed (or the screenshot/benchmark is done). Returns the exit code.
int RunViewer(const ViewerOptions& options);

}  // namespace objscan
