#include "viewer/viewer_app.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/bus.h"
#include "common/log.h"
#include "common/node.h"
#include "common/options.h"
#include "common/status.h"
#include "common/time.h"
#include "objscan/process_status_t.hpp"
#include "objscan/target_t.hpp"
#include "viewer/gl.h"
#include "viewer/log_player.h"

namespace objscan {
namespace {

constexpr double kDeg = M_PI / 180.0;

const char* ProcessStateName(int8_t state) {
  switch (state) {
    case process_status_t::STATE_STARTING:
      return "starting";
    case process_status_t::STATE_RUNNING:
      return "running";
    case process_status_t::STATE_IDLE:
      return "idle";
    case process_status_t::STATE_FINISHED:
      return "finished";
    case process_status_t::STATE_ERROR:
      return "ERROR";
    default:
      return "?";
  }
}

const char* TargetStateName(int8_t state) {
  switch (state) {
    case target_t::STATE_SEARCHING:
      return "searching";
    case target_t::STATE_CANDIDATE:
      return "candidate";
    case target_t::STATE_CONFIRMED:
      return "confirmed";
    case target_t::STATE_LOST:
      return "lost";
    default:
      return "?";
  }
}

LandmarkColoring ParseLandmarkColoring(const std::string& name) {
  if (name == "age") return LandmarkColoring::kAge;
  if (name == "rgb") return LandmarkColoring::kRgb;
  return LandmarkColoring::kReprojectionError;
}

// Benchmark models of n voxels (5 mm) on the floor, coloured by position: "ball" = a solid ball (after culling
// only its surface is drawn), "scatter" = voxels on every other lattice cell so that none has a neighbour (the
// worst case: every voxel drawn with three faces).
voxel_map_t SyntheticVoxelMap(int n, const std::string& shape) {
  if (shape == "scatter") {
    voxel_map_t map{};
    map.frame = "world";
    map.voxel_size_mm = 5.0;
    const int side = static_cast<int>(std::ceil(std::cbrt(static_cast<double>(n))));
    map.origin_mm[0] = map.origin_mm[1] = -side * map.voxel_size_mm;
    map.vote_threshold = 1;
    for (int i = 0; i < side && static_cast<int>(map.ijk.size()) < n; ++i)
      for (int j = 0; j < side && static_cast<int>(map.ijk.size()) < n; ++j)
        for (int k = 0; k < side && static_cast<int>(map.ijk.size()) < n; ++k) {
          map.ijk.push_back({2 * i, 2 * j, 2 * k});
          map.votes.push_back(1 + (i + j + k) % 7);
          map.rgb.push_back({static_cast<uint8_t>(60 + 190 * i / side), static_cast<uint8_t>(60 + 190 * j / side),
                             static_cast<uint8_t>(60 + 190 * k / side)});
        }
    map.num_voxels = static_cast<int32_t>(map.ijk.size());
    return map;
  }
  voxel_map_t map{};
  map.frame = "world";
  map.voxel_size_mm = 5.0;
  const int r = static_cast<int>(std::ceil(std::cbrt(3.0 * n / (4.0 * M_PI)))) + 1;
  map.origin_mm[0] = -r * map.voxel_size_mm;
  map.origin_mm[1] = -r * map.voxel_size_mm;
  map.origin_mm[2] = 0.0;
  map.vote_threshold = 1;
  std::vector<std::array<int, 3>> cells;
  for (int i = 0; i < 2 * r; ++i)
    for (int j = 0; j < 2 * r; ++j)
      for (int k = 0; k < 2 * r; ++k) {
        cells.push_back({i, j, k});
      }
  std::sort(cells.begin(), cells.end(), [r](const auto& a, const auto& b) {
    auto d = [r](const std::array<int, 3>& c) {
      const double x = c[0] + 0.5 - r, y = c[1] + 0.5 - r, z = c[2] + 0.5 - r;
      return x * x + y * y + z * z;
    };
    return d(a) < d(b);
  });
  cells.resize(std::min<size_t>(cells.size(), static_cast<size_t>(n)));
  for (const auto& c : cells) {
    map.ijk.push_back({c[0], c[1], c[2]});
    map.votes.push_back(1 + (c[0] + c[1] + c[2]) % 7);
    map.rgb.push_back({static_cast<uint8_t>(60 + 190 * c[0] / (2 * r)), static_cast<uint8_t>(60 + 190 * c[1] / (2 * r)),
                       static_cast<uint8_t>(60 + 190 * c[2] / (2 * r))});
  }
  map.num_voxels = static_cast<int32_t>(map.ijk.size());
  return map;
}

class Viewer {
 public:
  explicit Viewer(const ViewerOptions& options)
      : options_(options), dispatcher_(&state_, options.channels), view_(InitialView(options)) {
    if (!options.benchmark.empty()) ParseBenchmarkSpec(options.benchmark, &benchmark_, nullptr);  // validated
    ViewerStateOptions state_options;
    state_options.align_truth = options.align_truth;
    state_ = ViewerState(state_options);
    scene_.min_votes = options.min_votes;
    scene_.cull_hidden_voxels = options.cull_hidden_voxels;
    scene_.voxel_style = options.voxel_style == "cubes"    ? VoxelStyle::kCubes
                         : options.voxel_style == "points" ? VoxelStyle::kPoints
                                                           : VoxelStyle::kAuto;
    scene_.max_cube_instances = options.max_cube_instances;
    scene_.max_mesh_faces = options.max_mesh_faces;
    scene_.lod_pixels = options.voxel_lod_px;
    scene_.auto_points_px = options.voxel_points_px;
    scene_.occlusion_min_points = options.voxel_occlusion_min_points;
    scene_.landmark_coloring = ParseLandmarkColoring(options.landmark_coloring);
    scene_.max_reprojection_error_px = options.max_reprojection_error_px;
    follow_ = options.follow;
  }
  ~Viewer() { Shutdown(); }

  int Run();

 private:
  bool InitWindow();
  void Shutdown();
  void Handle(const std::string& channel, const void* data, int size, int64_t recv_utime);
  void PumpInputs(double wall_dt_s);
  void RenderFrame();
  void BuildPanels(const Viewport& scene_viewport);
  void PanelPlayback();
  void PanelImage();
  void PanelChannels();
  void PanelProcesses();
  void SceneOverlay(const Viewport& viewport);
  void HandleMouseAndKeys(const Viewport& viewport);
  int64_t Now() const { return player_ ? player_->current_utime() : WallTimeMicros(); }
  bool SaveScreenshot(const std::string& path);
  bool ScreenshotDue() const;
  int RunBenchmark();

  ViewerOptions options_;
  ViewerState state_;
  MessageDispatcher dispatcher_;
  BenchmarkSpec benchmark_;  // model "" = no benchmark
  OrbitView view_;
  SceneOptions scene_;
  std::unique_ptr<SceneRenderer> renderer_;
  bool follow_ = false;
  std::unique_ptr<Bus> bus_;
  std::unique_ptr<StatusReporter> status_;
  std::unique_ptr<LogPlayer> player_;
  GLFWwindow* window_ = nullptr;
  bool imgui_ready_ = false;
  unsigned image_texture_ = 0;
  int64_t image_texture_version_ = -1;
  int image_texture_width_ = 0, image_texture_height_ = 0;
  double fps_ = 0;
  int max_votes_ = 1;               // of the current voxel map (slider range)
  int64_t max_votes_version_ = -1;  // voxel map version max_votes_ belongs to
  float seek_s_ = 0;
  bool space_was_down_ = false, f_was_down_ = false;
  int64_t live_messages_ = 0;
};

bool Viewer::InitWindow() {
  glfwSetErrorCallback([](int code, const char* text) { LogError("glfw " + std::to_string(code) + ": " + text); });
  if (!glfwInit()) return false;
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_DEPTH_BITS, 24);
  glfwWindowHint(GLFW_RESIZABLE, options_.screenshot.empty() ? GLFW_TRUE : GLFW_FALSE);
  const std::string title = "objscan viewer - " + (options_.log.empty() ? std::string("live") : options_.log);
  window_ = glfwCreateWindow(options_.window_width, options_.window_height, title.c_str(), nullptr, nullptr);
  if (window_ == nullptr) return false;
  glfwMakeContextCurrent(window_);
  glfwSwapInterval(
      options_.vsync && benchmark_.model.empty() && options_.screenshot.empty() ? 1 : 0);
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // deterministic layout, no imgui.ini
  ImGui::StyleColorsDark();
  ImGui::GetStyle().CellPadding = ImVec2(3, 1);
  ImGui_ImplGlfw_InitForOpenGL(window_, true);
  ImGui_ImplOpenGL3_Init("#version 330 core");
  imgui_ready_ = true;
  std::string error;
  renderer_ = std::make_unique<SceneRenderer>();
  if (!renderer_->Init(&error)) {
    LogError("renderer: " + error);
    return false;
  }
  LogInfo(std::string("OpenGL ") + reinterpret_cast<const char*>(glGetString(GL_VERSION)) + " on " +
          reinterpret_cast<const char*>(glGetString(GL_RENDERER)));
  return true;
}

void Viewer::Shutdown() {
  if (image_texture_ != 0) glDeleteTextures(1, &image_texture_);
  image_texture_ = 0;
  if (imgui_ready_) {
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
    imgui_ready_ = false;
  }
  if (window_ != nullptr) {
    renderer_.reset();  // GL objects need the context
    glfwDestroyWindow(window_);
    window_ = nullptr;
    glfwTerminate();
  }
}

void Viewer::Handle(const std::string& channel, const void* data, int size, int64_t recv_utime) {
  ++live_messages_;
  const bool ok = dispatcher_.Dispatch(channel, data, size, recv_utime);
  if (status_) {
    status_->CountIn();
    if (!ok && state_.channels().at(channel).type != "unknown") status_->Reject(dispatcher_.last_error(), channel);
    status_->SetLastDataUtime(state_.latest_data_utime());
  }
}

void Viewer::PumpInputs(double wall_dt_s) {
  auto handler = [this](const std::string& channel, const void* data, int size, int64_t utime) {
    Handle(channel, data, size, utime);
  };
  if (player_) {
    player_->Advance(wall_dt_s, handler, options_.max_events_per_frame);
  } else if (bus_) {
    for (int i = 0; i < options_.max_events_per_frame && bus_->Handle(0) > 0; ++i) {
    }
    status_->SetValue("messages_unknown", static_cast<double>(state_.total_unknown()));
    status_->SetValue("render_fps", fps_);
    status_->PublishIfDue(WallTimeMicros());
  }
}

bool Viewer::ScreenshotDue() const {
  if (options_.screenshot_after_messages >= 0 && live_messages_ >= options_.screenshot_after_messages) return true;
  if (options_.screenshot_at_utime >= 0 && state_.latest_data_utime() >= options_.screenshot_at_utime) return true;
  return false;
}

void Viewer::HandleMouseAndKeys(const Viewport& viewport) {
  ImGuiIO& io = ImGui::GetIO();
  const bool in_scene = io.MousePos.x >= viewport.x && io.MousePos.x < viewport.x + viewport.width &&
                        io.MousePos.y >= viewport.y && io.MousePos.y < viewport.y + viewport.height;
  if (!io.WantCaptureMouse && in_scene) {
    if (io.MouseDown[0]) OrbitBy(&view_, io.MouseDelta.x, io.MouseDelta.y);
    if (io.MouseDown[1] || io.MouseDown[2]) {
      PanBy(&view_, viewport, io.MouseDelta.x, io.MouseDelta.y);
      follow_ = false;
    }
    if (io.MouseWheel != 0) ZoomBy(&view_, io.MouseWheel);
  }
  if (!io.WantCaptureKeyboard) {
    const bool space = glfwGetKey(window_, GLFW_KEY_SPACE) == GLFW_PRESS;
    const bool f = glfwGetKey(window_, GLFW_KEY_F) == GLFW_PRESS;
    if (space && !space_was_down_ && player_) player_->set_playing(!player_->playing());
    if (f && !f_was_down_) follow_ = !follow_;
    space_was_down_ = space;
    f_was_down_ = f;
  }
}

void Viewer::PanelPlayback() {
  auto reset = [this] { state_.Reset(); };
  struct FastForward {  // images are only decoded for the frame the seek lands on
    explicit FastForward(MessageDispatcher* d) : dispatcher(d) { dispatcher->BeginFastForward(); }
    ~FastForward() { dispatcher->EndFastForward(); }
    MessageDispatcher* dispatcher;
  };
  auto handler = [this](const std::string& channel, const void* data, int size, int64_t utime) {
    Handle(channel, data, size, utime);
  };
  if (!player_) {
    ImGui::Text("live: %s", bus_ ? bus_->Describe().c_str() : "-");
    return;
  }
  ImGui::TextWrapped("log: %s", options_.log.c_str());
  if (ImGui::Button(player_->playing() ? "Pause" : "Play")) player_->set_playing(!player_->playing());
  ImGui::SameLine();
  if (ImGui::Button("Step")) player_->Step(handler);
  ImGui::SameLine();
  if (ImGui::Button("+1 s")) {
    FastForward ff(&dispatcher_);
    player_->Seek(player_->current_utime() + 1000000, reset, handler);
  }
  ImGui::SameLine();
  if (ImGui::Button("Restart")) {
    FastForward ff(&dispatcher_);
    player_->Seek(player_->first_utime(), reset, handler);
  }
  float speed = static_cast<float>(player_->speed());
  if (ImGui::SliderFloat("speed", &speed, 0.05f, 20.0f, "%.2fx", ImGuiSliderFlags_Logarithmic))
    player_->set_speed(speed);
  const float span_s = static_cast<float>((player_->last_utime() - player_->first_utime()) * 1e-6);
  if (!ImGui::IsItemActive()) seek_s_ = static_cast<float>((player_->current_utime() - player_->first_utime()) * 1e-6);
  ImGui::SliderFloat("time s", &seek_s_, 0.0f, std::max(span_s, 0.001f), "%.2f");
  if (ImGui::IsItemDeactivatedAfterEdit()) {
    FastForward ff(&dispatcher_);
    player_->Seek(player_->first_utime() + static_cast<int64_t>(seek_s_ * 1e6), reset, handler);
  }
  ImGui::Text("events %lld / %lld%s", static_cast<long long>(player_->events_delivered()),
              static_cast<long long>(player_->num_events()), player_->at_end() ? "  (end of log)" : "");
}

void Viewer::PanelImage() {
  if (!state_.image()) {
    ImGui::TextDisabled("no image yet");
    return;
  }
  const ImageFrame& frame = *state_.image();
  if (image_texture_version_ != state_.image_version()) {
    cv::Mat rgb;
    if (frame.image.channels() == 1)
      cv::cvtColor(frame.image, rgb, cv::COLOR_GRAY2RGB);
    else
      cv::cvtColor(frame.image, rgb, cv::COLOR_BGR2RGB);
    if (image_texture_ == 0) glGenTextures(1, &image_texture_);
    glBindTexture(GL_TEXTURE_2D, image_texture_);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, static_cast<int>(rgb.step / 3));
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB8, rgb.cols, rgb.rows, 0, GL_RGB, GL_UNSIGNED_BYTE, rgb.data);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    image_texture_version_ = state_.image_version();
    image_texture_width_ = rgb.cols;
    image_texture_height_ = rgb.rows;
  }
  // As wide as the panel, at most 200 px high (leaves room for the tables below).
  const float scale = std::min(ImGui::GetContentRegionAvail().x / std::max(image_texture_width_, 1),
                               200.0f / std::max(image_texture_height_, 1));
  const float width = image_texture_width_ * scale;
  const ImVec2 origin = ImGui::GetCursorScreenPos();
  ImGui::Image(reinterpret_cast<ImTextureID>(static_cast<intptr_t>(image_texture_)),
               ImVec2(width, image_texture_height_ * scale));
  const TrackFrame* tracks = state_.TracksFor(frame.seq);
  int drawn = 0;
  if (tracks != nullptr) {
    ImDrawList* draw = ImGui::GetWindowDrawList();
    for (const TrackedFeature& f : tracks->features) {
      const float t = std::min(f.age / 30.0f, 1.0f);  // young green -> old red
      const ImU32 color = IM_COL32(static_cast<int>(255 * t), static_cast<int>(255 * (1 - t)), 40, 255);
      draw->AddCircle(ImVec2(origin.x + (f.u + 0.5f) * scale, origin.y + (f.v + 0.5f) * scale), 3.0f, color, 8);
      ++drawn;
    }
  }
  ImGui::Text("%s seq %lld  %dx%d  tracks %d%s", frame.camera_name.c_str(), static_cast<long long>(frame.seq),
              frame.image.cols, frame.image.rows, drawn,
              tracks != nullptr && tracks->seq != frame.seq ? " (of another frame)" : "");
}

void Viewer::PanelChannels() {
  const int64_t now = Now();
  if (ImGui::BeginTable("channels", 7,
                        ImGuiTableFlags_RowBg | ImGuiTableFlags_Borders | ImGuiTableFlags_SizingFixedFit)) {
    for (const char* h : {"channel", "type", "msgs", "Hz", "age s", "drops", "bad"}) ImGui::TableSetupColumn(h);
    ImGui::TableHeadersRow();
    for (const auto& [name, stats] : state_.channels()) {
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(name.c_str());
      ImGui::TableNextColumn();
      if (stats.type == "unknown")
        ImGui::TextColored(ImVec4(1, 0.6f, 0.2f, 1), "unknown");
      else
        ImGui::TextUnformatted(stats.type.c_str());
      ImGui::TableNextColumn();
      ImGui::Text("%lld", static_cast<long long>(stats.messages));
      ImGui::TableNextColumn();
      ImGui::Text("%.1f", state_.ChannelRate(name, now));
      ImGui::TableNextColumn();
      ImGui::Text("%.1f", std::max<int64_t>(0, now - stats.last_recv_utime) * 1e-6);
      ImGui::TableNextColumn();
      ImGui::Text("%lld", static_cast<long long>(stats.dropped));
      ImGui::TableNextColumn();
      if (stats.malformed > 0)
        ImGui::TextColored(ImVec4(1, 0.3f, 0.3f, 1), "%lld", static_cast<long long>(stats.malformed));
      else
        ImGui::TextUnformatted("0");
    }
    ImGui::EndTable();
  }
  ImGui::Text("unknown messages %lld, malformed %lld", static_cast<long long>(state_.total_unknown()),
              static_cast<long long>(state_.total_malformed()));
  for (const auto& [reason, count] : state_.malformed_reasons())
    ImGui::TextColored(ImVec4(1, 0.4f, 0.4f, 1), "  %s: %lld", reason.c_str(), static_cast<long long>(count));
}

void Viewer::PanelProcesses() {
  if (state_.processes().empty()) {
    ImGui::TextDisabled("no PROCESS_STATUS yet");
    return;
  }
  const int64_t now = Now();
  if (ImGui::BeginTable("processes", 8,
                        ImGuiTableFlags_RowBg | ImGuiTableFlags_Borders | ImGuiTableFlags_SizingFixedFit)) {
    for (const char* h : {"process", "state", "in", "out", "rej", "drop", "p50 ms", "age s"})
      ImGui::TableSetupColumn(h);
    ImGui::TableHeadersRow();
    for (const auto& [name, entry] : state_.processes()) {
      const process_status_t& s = entry.status;
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(name.c_str());
      ImGui::TableNextColumn();
      if (s.state == process_status_t::STATE_ERROR)
        ImGui::TextColored(ImVec4(1, 0.3f, 0.3f, 1), "%s", ProcessStateName(s.state));
      else
        ImGui::TextUnformatted(ProcessStateName(s.state));
      if (!s.state_detail.empty() && ImGui::IsItemHovered()) ImGui::SetTooltip("%s", s.state_detail.c_str());
      ImGui::TableNextColumn();
      ImGui::Text("%lld", static_cast<long long>(s.messages_in));
      ImGui::TableNextColumn();
      ImGui::Text("%lld", static_cast<long long>(s.messages_out));
      ImGui::TableNextColumn();
      ImGui::Text("%lld", static_cast<long long>(s.messages_rejected));
      if (s.num_rejection_reasons > 0 && ImGui::IsItemHovered()) {
        std::string text;
        for (int i = 0; i < s.num_rejection_reasons && i < static_cast<int>(s.rejection_reason.size()) &&
                        i < static_cast<int>(s.rejection_count.size());
             ++i)
          text += s.rejection_reason[i] + ": " + std::to_string(s.rejection_count[i]) + "\n";
        ImGui::SetTooltip("%s", text.c_str());
      }
      ImGui::TableNextColumn();
      ImGui::Text("%lld", static_cast<long long>(s.dropped_inputs));
      ImGui::TableNextColumn();
      ImGui::Text("%.1f", s.latency_p50_ms);
      ImGui::TableNextColumn();
      ImGui::Text("%.1f", std::max<int64_t>(0, now - entry.recv_utime) * 1e-6);
    }
    ImGui::EndTable();
  }
}

void Viewer::BuildPanels(const Viewport& scene_viewport) {
  if (options_.panel_width <= 0) return;
  const ImVec2 display = ImGui::GetIO().DisplaySize;
  ImGui::SetNextWindowPos(ImVec2(static_cast<float>(scene_viewport.x + scene_viewport.width), 0), ImGuiCond_Always);
  ImGui::SetNextWindowSize(ImVec2(display.x - (scene_viewport.x + scene_viewport.width), display.y), ImGuiCond_Always);
  // No ImGui background: RenderFrame clears the column to the same colour with glClear, which in software GL is far
  // cheaper than ImGui's blended, textured full-height rectangle (about 17 ms per frame on llvmpipe).
  ImGui::Begin("objscan viewer", nullptr,
               ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse |
                   ImGuiWindowFlags_NoBackground);
  if (ImGui::CollapsingHeader("Source", ImGuiTreeNodeFlags_DefaultOpen)) PanelPlayback();
  if (ImGui::CollapsingHeader("View and layers", ImGuiTreeNodeFlags_DefaultOpen)) {
    SceneLayers& l = scene_.layers;
    ImGui::Checkbox("grid", &l.grid);
    ImGui::SameLine();
    ImGui::Checkbox("axes", &l.axes);
    ImGui::SameLine();
    ImGui::Checkbox("robot", &l.robot);
    ImGui::SameLine();
    ImGui::Checkbox("target", &l.target);
    ImGui::Checkbox("estimate", &l.estimated);
    ImGui::SameLine();
    ImGui::Checkbox("frustums", &l.frustums);
    ImGui::SameLine();
    ImGui::Checkbox("truth", &l.ground_truth);
    ImGui::SameLine();
    ImGui::Checkbox("error", &l.error);
    ImGui::Checkbox("landmarks", &l.landmarks);
    ImGui::SameLine();
    ImGui::Checkbox("voxels", &l.voxels);
    ImGui::SameLine();
    ImGui::Checkbox("follow camera", &follow_);
    int coloring = static_cast<int>(scene_.landmark_coloring);
    if (ImGui::Combo("landmark colour", &coloring, "reprojection error\0age\0own colour\0"))
      scene_.landmark_coloring = static_cast<LandmarkColoring>(coloring);
    if (max_votes_version_ != state_.voxel_map_version()) {  // once per map, not per frame
      max_votes_version_ = state_.voxel_map_version();
      max_votes_ = 1;
      if (state_.voxel_map())
        for (int v : state_.voxel_map()->votes) max_votes_ = std::max(max_votes_, v);
    }
    ImGui::SliderInt("min votes", &scene_.min_votes, 0, max_votes_);
    int style = static_cast<int>(scene_.voxel_style);
    if (ImGui::Combo("voxel style", &style, "auto\0cubes\0points\0"))
      scene_.voxel_style = static_cast<VoxelStyle>(style);
    bool by_votes = scene_.voxel_coloring == VoxelColoring::kVotes;
    if (ImGui::Checkbox("colour voxels by votes", &by_votes))
      scene_.voxel_coloring = by_votes ? VoxelColoring::kVotes : VoxelColoring::kRgb;
    for (const char* preset : {"iso", "top", "front", "side"}) {
      if (ImGui::Button(preset)) ApplyViewPreset(preset, &view_);
      ImGui::SameLine();
    }
    if (ImGui::Button("reset view")) view_ = InitialView(options_);
  }
  if (ImGui::CollapsingHeader("Data", ImGuiTreeNodeFlags_DefaultOpen)) {
    ImGui::Text("poses: estimated %zu, truth %zu", state_.estimated_trajectory().size(),
                state_.ground_truth_trajectory().size());
    if (state_.latest_position_error_mm())
      ImGui::Text("position error%s %.1f mm (seq %lld), rms %.1f mm over %lld",
                  state_.truth_aligned() ? " (Sim3-aligned)" : "", *state_.latest_position_error_mm(),
                  static_cast<long long>(state_.latest_error_seq()), state_.position_error_rms_mm(),
                  static_cast<long long>(state_.position_error_count()));
    ImGui::Text("landmarks %d, voxels %lld shown (%lld drawn) of %d",
                state_.landmarks() ? state_.landmarks()->num_landmarks : 0,
                static_cast<long long>(renderer_->voxels_shown()), static_cast<long long>(renderer_->voxels_drawn()),
                state_.voxel_map() ? state_.voxel_map()->num_voxels : 0);
    if (renderer_->voxel_level() > 0 || renderer_->voxels_occlusion_culled())
      ImGui::Text("  voxels as points%s, level of detail %d (cells of %d voxels per side)",
                  renderer_->voxels_occlusion_culled() ? " (visible ones only)" : "", renderer_->voxel_level(),
                  1 << renderer_->voxel_level());
    if (state_.target()) {
      const target_t& t = *state_.target();
      ImGui::Text("target %s conf %.2f at (%.0f, %.0f, %.0f) mm", TargetStateName(t.state), t.confidence,
                  t.center_mm[0], t.center_mm[1], t.center_mm[2]);
    }
    if (state_.odometry())
      ImGui::Text("odometry x %.0f y %.0f mm, theta %.1f deg", state_.odometry()->x_mm, state_.odometry()->y_mm,
                  state_.odometry()->theta_rad / kDeg);
    if (state_.model()) ImGui::TextWrapped("model: %s", state_.model()->voxels_ply_path.c_str());
  }
  if (ImGui::CollapsingHeader("Camera image", ImGuiTreeNodeFlags_DefaultOpen)) PanelImage();
  if (ImGui::CollapsingHeader("Channels", ImGuiTreeNodeFlags_DefaultOpen)) PanelChannels();
  if (ImGui::CollapsingHeader("Processes", ImGuiTreeNodeFlags_DefaultOpen)) PanelProcesses();
  ImGui::End();
}

void Viewer::SceneOverlay(const Viewport& viewport) {
  ImDrawList* draw = ImGui::GetForegroundDrawList();
  char text[256];
  const double t =
      player_ ? (player_->current_utime() - player_->first_utime()) * 1e-6 : state_.latest_data_utime() * 1e-6;
  std::snprintf(text, sizeof(text), "%s t=%.2f s   %.0f fps%s%s", player_ ? "log" : "live", t, fps_,
                follow_ ? "   follow" : "", player_ && player_->at_end() ? "   end of log" : "");
  draw->AddText(ImVec2(viewport.x + 8.0f, viewport.y + 6.0f), IM_COL32(230, 230, 230, 255), text);
  if (state_.latest_position_error_mm()) {
    std::snprintf(text, sizeof(text), "position error %.1f mm", *state_.latest_position_error_mm());
    draw->AddText(ImVec2(viewport.x + 8.0f, viewport.y + 22.0f), IM_COL32(255, 120, 220, 255), text);
  }
  if (scene_.layers.target && state_.target()) {
    const target_t& tg = *state_.target();
    Eigen::Vector2d pixel;
    const Eigen::Vector3d top(tg.center_mm[0], tg.center_mm[1], tg.center_mm[2] + tg.size_mm[2] / 2);
    if (ProjectToWindow(view_, viewport, top, &pixel)) {
      std::snprintf(text, sizeof(text), "target: %s %.2f", TargetStateName(tg.state), tg.confidence);
      draw->AddText(ImVec2(static_cast<float>(pixel.x()), static_cast<float>(pixel.y()) - 16),
                    IM_COL32(255, 255, 120, 255), text);
    }
  }
}

void Viewer::RenderFrame() {
  int fb_width = 0, fb_height = 0;
  glfwGetFramebufferSize(window_, &fb_width, &fb_height);
  const Viewport viewport = SceneViewport(fb_width, fb_height, options_.panel_width);
  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGui::NewFrame();
  HandleMouseAndKeys(viewport);
  if (follow_) {
    if (!state_.estimated_trajectory().empty())
      view_.target_mm = state_.estimated_trajectory().rbegin()->second.world_from_camera.translation();
    else if (state_.odometry())
      view_.target_mm = Eigen::Vector3d(state_.odometry()->x_mm, state_.odometry()->y_mm, 0);
  }
  BuildPanels(viewport);
  SceneOverlay(viewport);
  ImGui::Render();
  glViewport(0, 0, fb_width, fb_height);
  glClearColor(0.1f, 0.1f, 0.12f, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  if (options_.panel_width > 0) {  // the panel column's background (the panel window draws none)
    const ImVec4 bg = ImGui::GetStyleColorVec4(ImGuiCol_WindowBg);
    const int x = viewport.x + viewport.width;
    glEnable(GL_SCISSOR_TEST);
    glScissor(x, 0, std::max(fb_width - x, 0), fb_height);
    // WindowBg blended over the clear colour, as ImGui would have drawn it.
    glClearColor(bg.x * bg.w + 0.1f * (1 - bg.w), bg.y * bg.w + 0.1f * (1 - bg.w), bg.z * bg.w + 0.12f * (1 - bg.w),
                 1.0f);
    glClear(GL_COLOR_BUFFER_BIT);
    glDisable(GL_SCISSOR_TEST);
  }
  renderer_->Render(state_, view_, viewport, fb_height, scene_);
  glViewport(0, 0, fb_width, fb_height);
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
}

bool Viewer::SaveScreenshot(const std::string& path) {
  int fb_width = 0, fb_height = 0;
  glfwGetFramebufferSize(window_, &fb_width, &fb_height);
  // Render into an offscreen framebuffer so the result does not depend on window visibility.
  unsigned fbo = 0, color = 0, depth = 0;
  glGenFramebuffers(1, &fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  glGenRenderbuffers(1, &color);
  glBindRenderbuffer(GL_RENDERBUFFER, color);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, fb_width, fb_height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color);
  glGenRenderbuffers(1, &depth);
  glBindRenderbuffer(GL_RENDERBUFFER, depth);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH24_STENCIL8, fb_width, fb_height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_STENCIL_ATTACHMENT, GL_RENDERBUFFER, depth);
  bool ok = glCheckFramebufferStatus(GL_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE;
  cv::Mat rgb(fb_height, fb_width, CV_8UC3);
  if (ok) {
    RenderFrame();
    glFinish();
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, fb_width, fb_height, GL_RGB, GL_UNSIGNED_BYTE, rgb.data);
  }
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glDeleteRenderbuffers(1, &color);
  glDeleteRenderbuffers(1, &depth);
  glDeleteFramebuffers(1, &fbo);
  if (!ok) {
    LogError("screenshot: offscreen framebuffer incomplete");
    return false;
  }
  cv::Mat bgr;
  cv::flip(rgb, rgb, 0);  // GL rows run bottom-up
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  try {
    if (!cv::imwrite(path, bgr)) {
      LogError("screenshot: cannot write " + path);
      return false;
    }
  } catch (const cv::Exception& e) {
    LogError(std::string("screenshot: ") + e.what());
    return false;
  }
  LogInfo("screenshot " + path + " (" + std::to_string(fb_width) + "x" + std::to_string(fb_height) + ")");
  return true;
}

int Viewer::RunBenchmark() {
  std::string model;
  double first_frame_ms = 0;
  if (player_) {  // the scene at the end of the log, panels and camera image included
    auto handler = [this](const std::string& channel, const void* data, int size, int64_t utime) {
      Handle(channel, data, size, utime);
    };
    dispatcher_.BeginFastForward();
    player_->DeliverUntil(player_->last_utime(), handler);
    dispatcher_.EndFastForward();
    player_->set_playing(false);
    model = "log " + options_.log;
    if (state_.voxel_map() && !state_.voxel_map()->ijk.empty()) {  // orbit around the model's centre
      const voxel_map_t& map = *state_.voxel_map();
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (const auto& ijk : map.ijk)
        for (int a = 0; a < 3; ++a) sum[a] += map.origin_mm[a] + (ijk[a] + 0.5) * map.voxel_size_mm;
      view_.target_mm = sum / static_cast<double>(map.ijk.size());
    }
  } else {
    state_.SetVoxelMap(SyntheticVoxelMap(benchmark_.voxels, benchmark_.model));
    view_.target_mm = Eigen::Vector3d(0, 0, 200);
    view_.distance_mm = std::max(view_.distance_mm, 1200.0);
    model = benchmark_.model;
  }
  // Warm-up frames (buffer uploads, ImGui layout) outside the timing; the first one builds the voxel buffers.
  const int64_t warm_up_start = MonotonicMicros();
  for (int i = 0; i < 3; ++i) {
    glfwPollEvents();
    RenderFrame();
    glfwSwapBuffers(window_);
    if (i == 0) {
      glFinish();
      first_frame_ms = (MonotonicMicros() - warm_up_start) * 1e-3;
    }
  }
  glFinish();
  auto cpu_micros = [](clockid_t clock) {
    timespec ts{};
    clock_gettime(clock, &ts);
    return ts.tv_sec * 1000000LL + ts.tv_nsec / 1000;
  };
  const int64_t start = MonotonicMicros();
  const int64_t process_cpu_start = cpu_micros(CLOCK_PROCESS_CPUTIME_ID);
  const int64_t thread_cpu_start = cpu_micros(CLOCK_THREAD_CPUTIME_ID);
  int frames = 0;
  int64_t slowest_us = 0, previous = start;
  // Orbit: the view changes every frame, so every frame is rendered from scratch.
  while (!glfwWindowShouldClose(window_)) {
    if (MonotonicMicros() - start >= benchmark_.seconds * 1e6) break;
    glfwPollEvents();
    view_.yaw_rad += 0.01;
    RenderFrame();
    glfwSwapBuffers(window_);
    ++frames;
    const int64_t now = MonotonicMicros();
    slowest_us = std::max(slowest_us, now - previous);
    previous = now;
  }
  glFinish();
  const double seconds = (MonotonicMicros() - start) * 1e-6;
  const double process_cpu_ms = (cpu_micros(CLOCK_PROCESS_CPUTIME_ID) - process_cpu_start) * 1e-3 / std::max(frames, 1);
  const double thread_cpu_ms = (cpu_micros(CLOCK_THREAD_CPUTIME_ID) - thread_cpu_start) * 1e-3 / std::max(frames, 1);
  const char* path = renderer_->voxels_as_points() ? "points"
                     : renderer_->voxels_as_mesh() ? "cubes, face mesh"
                                                   : "cubes, instanced";
  std::printf(
      "benchmark (%s, %s, level of detail %d): %lld voxels (%lld drawn after hidden-voxel culling %s), %dx%d window, "
      "%d frames in %.2f s = %.1f frames/s, slowest frame %.1f ms, CPU per frame %.1f ms (main thread %.1f ms), "
      "first frame with the model upload %.0f ms (%s)\n",
      model.c_str(), path, renderer_->voxel_level(), static_cast<long long>(renderer_->voxels_shown()),
      static_cast<long long>(renderer_->voxels_drawn()), options_.cull_hidden_voxels ? "on" : "off",
      options_.window_width, options_.window_height, frames, seconds, frames / seconds, slowest_us * 1e-3,
      process_cpu_ms, thread_cpu_ms, first_frame_ms, reinterpret_cast<const char*>(glGetString(GL_RENDERER)));
  std::fflush(stdout);
  if (!options_.screenshot.empty()) return SaveScreenshot(options_.screenshot) ? 0 : 1;  // the view after the orbit
  return 0;
}

int Viewer::Run() {
  if (!options_.log.empty()) {
    player_ = std::make_unique<LogPlayer>();
    std::string error;
    if (!player_->Open(options_.log, &error)) {
      LogError(error);
      return 1;
    }
    player_->set_speed(options_.speed);
    player_->set_playing(!options_.paused);
    LogInfo("log " + options_.log + ": " + std::to_string(player_->num_events()) + " events, " +
            std::to_string((player_->last_utime() - player_->first_utime()) * 1e-6) + " s");
  } else if (benchmark_.model.empty()) {
    try {
      bus_ = MakeLcmBus(options_.lcm_url.empty() ? kDefaultLcmUrl : options_.lcm_url);
      bus_->Subscribe(
          ".*", [this](const RawMessage& raw) { Handle(raw.channel, raw.data, raw.size, raw.recv_utime); }, 1000);
    } catch (const std::exception& e) {
      LogError(e.what());
      return 1;
    }
    status_ = std::make_unique<StatusReporter>(bus_.get(), options_.name, options_.status_channel);
    status_->SetState(process_status_t::STATE_RUNNING);
    LogInfo("bus " + bus_->Describe());
  }
  if (!InitWindow()) {
    LogError("cannot open an OpenGL 3.3 window (is DISPLAY set? try xvfb-run)");
    return 1;
  }
  if (!benchmark_.model.empty()) return RunBenchmark();

  auto handler = [this](const std::string& channel, const void* data, int size, int64_t utime) {
    Handle(channel, data, size, utime);
  };
  if (!options_.screenshot.empty() && player_) {
    // Headless: feed the log as fast as possible up to the chosen point, then render and save.
    dispatcher_.BeginFastForward();
    if (options_.screenshot_after_messages >= 0) {
      while (live_messages_ < options_.screenshot_after_messages && player_->Step(handler)) {
      }
    } else if (options_.screenshot_at_utime >= 0) {
      player_->DeliverUntil(options_.screenshot_at_utime, handler);
    } else {
      player_->DeliverUntil(player_->last_utime(), handler);
    }
    dispatcher_.EndFastForward();
    for (int i = 0; i < 3; ++i) {  // let ImGui settle its layout
      glfwPollEvents();
      RenderFrame();
      glfwSwapBuffers(window_);
    }
    return SaveScreenshot(options_.screenshot) ? 0 : 1;
  }

  const int64_t start = MonotonicMicros();
  int64_t last = start, fps_start = start;
  int fps_frames = 0;
  while (!glfwWindowShouldClose(window_) && !StopRequested()) {
    glfwPollEvents();
    const int64_t now = MonotonicMicros();
    PumpInputs((now - last) * 1e-6);
    last = now;
    if (!options_.screenshot.empty() && (ScreenshotDue() || now - start > options_.screenshot_timeout_s * 1e6)) {
      for (int i = 0; i < 2; ++i) {
        RenderFrame();
        glfwSwapBuffers(window_);
      }
      return SaveScreenshot(options_.screenshot) ? 0 : 1;
    }
    RenderFrame();
    glfwSwapBuffers(window_);
    ++fps_frames;
    if (now - fps_start > 1000000) {
      fps_ = fps_frames / ((now - fps_start) * 1e-6);
      fps_frames = 0;
      fps_start = now;
    }
    if (!options_.vsync) glfwWaitEventsTimeout(0.001);
  }
  if (status_) {
    status_->SetState(process_status_t::STATE_FINISHED);
    status_->PublishIfDue(WallTimeMicros(), true);
  }
  return 0;
}

}  // namespace

void AddViewerOptions(OptionParser& parser, ViewerOptions* o) {
  // Only what a user sets (issue 27): plumbing and channels (the processes' channels can be renamed), the bus or log,
  // the window and view, playback, the screenshot, the benchmark and the voxel drawing paths viewer_render_test
  // chooses. The start-up state the panels change at run time (follow, min votes, landmark colouring, its red error),
  // vsync, the cube-instance limit, the event budget, the hidden-face culling and the auto style's point size keep
  // their defaults here; tests and code set the struct directly.
  parser.Add("name", &o->name, "process name (status name, log prefix)");
  parser.Add("lcm-url", &o->lcm_url, "live LCM URL (default: the objscan multicast URL); ignored with --log");
  parser.Add("log", &o->log, "LCM log file to play instead of a live bus");
  ViewerChannels& c = o->channels;
  parser.AddChannel(&c.camera_pose, "estimated camera poses (pose_t)");
  parser.AddChannel(&c.ground_truth, "true camera poses (pose_t)");
  parser.AddChannel(&c.landmarks, "sparse map (landmarks_t)");
  parser.AddChannel(&c.voxel_map, "dense model (voxel_map_t)");
  parser.AddChannel(&c.target, "object estimate (target_t)");
  parser.AddChannel(&c.odometry, "robot odometry (odometry_t)");
  parser.AddChannel(&c.image, "camera frames (image_t)");
  parser.AddChannel(&c.camera_info, "camera calibration (camera_info_t)");
  parser.AddChannel(&c.tracks, "feature tracks (feature_tracks_t)");
  parser.AddChannel(&c.status, "process status read (process_status_t)");
  parser.AddChannel(&c.control, "session events (control_t)");
  parser.AddChannel(&c.model, "final model notices (model_t)");
  parser.AddChannel(&o->status_channel, "channel of the viewer's own status (live only)");
  parser.Add("window-width", &o->window_width, "px, window width");
  parser.Add("window-height", &o->window_height, "px, window height");
  parser.Add("panel-width", &o->panel_width, "px, width of the panel column on the right (0 = no panels)");
  parser.Add("align-truth", &o->align_truth,
             "draw the ground truth in the estimate's frame (Sim(3) fit over matched frames) and measure errors there");
  parser.Add("view", &o->view,
             "initial view: a preset (iso, top, front, side) or YAW,PITCH in deg, then optionally ,DISTANCE in mm "
             "(3000), then ,X,Y,Z the view target in mm (0,0,0), then ,FOV in deg (50); e.g. top,800 or "
             "-90,70,4000,0,0,100,50");
  parser.Add("speed", &o->speed, "log playback speed");
  parser.Add("paused", &o->paused, "start the log paused");
  parser.Add("screenshot", &o->screenshot, "write a PNG of the window and exit");
  parser.Add("screenshot-at-utime", &o->screenshot_at_utime, "us, take the screenshot once this time is reached");
  parser.Add("screenshot-after-messages", &o->screenshot_after_messages, "take the screenshot after N messages");
  parser.Add("screenshot-timeout-s", &o->screenshot_timeout_s, "s, live: take the screenshot anyway after this");
  parser.Add("benchmark", &o->benchmark,
             "orbit the view and print frames/s: log (the scene at the end of --log), ball:N or scatter:N (a "
             "synthetic model of N voxels, solid or none touching another); @S for S seconds instead of 5, e.g. "
             "scatter:200000@6");
  parser.Add("voxel-style", &o->voxel_style, "voxels as cubes, points, or auto (points above max_cube_instances)");
  parser.Add("max-mesh-faces", &o->max_mesh_faces,
             "exposed voxel faces drawn as one static mesh at most (else instanced)");
  parser.Add("voxel-lod-px", &o->voxel_lod_px,
             "px, draw merged 2x2x2.. voxel cells as points while they project at most this wide (0 = off)");
  parser.Add("voxel-occlusion-min-points", &o->voxel_occlusion_min_points,
             "points: send only the points a CPU depth pass finds visible, from this many points (0 = off)");
}

bool ValidateViewerOptions(const ViewerOptions& o, std::string* why) {
  auto fail = [why](const std::string& reason) {
    if (why) *why = reason;
    return false;
  };
  OrbitView view;
  std::string view_why;
  if (!ParseViewSpec(o.view, &view, &view_why)) return fail(view_why);
  if (o.window_width < 64 || o.window_height < 64 || o.window_width > 8192 || o.window_height > 8192)
    return fail("--window-width/--window-height must be in 64..8192");
  if (o.panel_width < 0 || o.panel_width > o.window_width - 32) return fail("--panel-width must be in 0..width-32");
  if (!(o.speed > 0)) return fail("--speed must be > 0");
  if (!o.benchmark.empty()) {
    BenchmarkSpec benchmark;
    std::string benchmark_why;
    if (!ParseBenchmarkSpec(o.benchmark, &benchmark, &benchmark_why)) return fail(benchmark_why);
    if (benchmark.model == "log" && o.log.empty()) return fail("--benchmark log needs --log");
    if (benchmark.model != "log" && !o.log.empty())
      return fail("--benchmark " + benchmark.model + ":N renders a synthetic model, not --log (use --benchmark log)");
  }
  if (o.voxel_style != "auto" && o.voxel_style != "cubes" && o.voxel_style != "points")
    return fail("--voxel-style must be auto, cubes or points");
  if (o.max_cube_instances < 0 || o.max_mesh_faces < 0) return fail("max_cube_instances / --max-mesh-faces >= 0");
  if (!(o.voxel_lod_px >= 0) || !(o.voxel_points_px >= 0) || o.voxel_occlusion_min_points < 0)
    return fail("--voxel-lod-px >= 0, voxel_points_px >= 0, --voxel-occlusion-min-points >= 0");
  if (o.landmark_coloring != "error" && o.landmark_coloring != "age" && o.landmark_coloring != "rgb")
    return fail("landmark_coloring must be error, age or rgb");
  if (!(o.max_reprojection_error_px > 0)) return fail("max_reprojection_error_px must be > 0");
  if (o.max_events_per_frame < 1) return fail("max_events_per_frame must be >= 1");
  if (o.screenshot.empty() && (o.screenshot_at_utime >= 0 || o.screenshot_after_messages >= 0))
    return fail("--screenshot-at-utime / --screenshot-after-messages need --screenshot");
  return true;
}

bool ParseBenchmarkSpec(const std::string& spec, BenchmarkSpec* benchmark, std::string* why) {
  auto fail = [&](const std::string& reason) {
    if (why) *why = "--benchmark '" + spec + "': " + reason;
    return false;
  };
  constexpr const char* kForm = "want log, ball:N or scatter:N (N voxels > 0), optionally @SECONDS (> 0)";
  BenchmarkSpec b;
  std::string model = spec;
  const auto at = spec.find('@');
  if (at != std::string::npos) {
    model = spec.substr(0, at);
    if (!ParseFiniteNumber(spec.substr(at + 1), &b.seconds) || !(b.seconds > 0))
      return fail("seconds '" + spec.substr(at + 1) + "' must be a number > 0; " + kForm);
  }
  const auto colon = model.find(':');
  b.model = model.substr(0, colon);
  if (b.model == "log") {
    if (colon != std::string::npos) return fail(std::string("log takes no voxel count; ") + kForm);
  } else if (b.model == "ball" || b.model == "scatter") {
    double n = 0;
    if (colon == std::string::npos) return fail(b.model + " needs its voxel count, e.g. " + b.model + ":200000");
    const std::string count = model.substr(colon + 1);
    if (!ParseFiniteNumber(count, &n) || n < 1 || n > 1e8 || n != std::floor(n))
      return fail("voxel count '" + count + "' must be a whole number in 1..100000000");
    b.voxels = static_cast<int>(n);
  } else {
    return fail("unknown model '" + b.model + "'; " + kForm);
  }
  *benchmark = b;
  return true;
}

OrbitView InitialView(const ViewerOptions& o) {
  OrbitView view;
  if (!ParseViewSpec(o.view, &view, nullptr)) return OrbitView();
  return view;
}

Viewport SceneViewport(int framebuffer_width, int framebuffer_height, int panel_width) {
  Viewport v;
  v.width = std::max(1, framebuffer_width - std::max(panel_width, 0));
  v.height = std::max(1, framebuffer_height);
  return v;
}

int RunViewer(const ViewerOptions& options) {
  Viewer viewer(options);
  return viewer.Run();
}

}  // namespace objscan
