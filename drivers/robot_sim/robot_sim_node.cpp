#include "drivers/robot_sim/robot_sim_node.h"

#include <cmath>
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "common/adapters.h"
#include "common/bus.h"
#include "common/json_writer.h"
#include "common/log.h"
#include "common/options.h"
#include "common/recorded_run.h"
#include "common/time.h"
#include "objscan/camera_info_t.hpp"
#include "objscan/control_t.hpp"
#include "objscan/image_t.hpp"
#include "objscan/odometry_t.hpp"
#include "objscan/pose_t.hpp"
#include "objscan/process_status_t.hpp"
#include "objscan/robot_command_t.hpp"

namespace objscan {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

bool EncodingFromName(const std::string& name, int8_t* encoding) {
  if (name == "gray8")
    *encoding = image_t::ENCODING_GRAY8;
  else if (name == "rgb8")
    *encoding = image_t::ENCODING_RGB8;
  else if (name == "bgr8")
    *encoding = image_t::ENCODING_BGR8;
  else if (name == "jpeg")
    *encoding = image_t::ENCODING_JPEG;
  else
    return false;
  return true;
}

// Parses "a,b" / "a,b,c" into values; false on a wrong count or a non-finite number.
bool ParseList(const std::string& text, size_t count, double* values) {
  std::vector<double> parsed;
  if (!ParseNumberList(text, &parsed) || parsed.size() != count) return false;
  std::copy(parsed.begin(), parsed.end(), values);
  return true;
}

// "FIRST,COUNT" (whole numbers >= 0) into *first, *count; "" = none (count 0).
bool ParseBlank(const std::string& text, int64_t* first, int64_t* count) {
  *first = *count = 0;
  if (text.empty()) return true;
  double values[2];
  if (!ParseList(text, 2, values)) return false;
  for (double v : values)
    if (v < 0 || v > 1e12 || v != std::floor(v)) return false;
  *first = static_cast<int64_t>(values[0]);
  *count = static_cast<int64_t>(values[1]);
  return true;
}

}  // namespace

void AddRobotSimNodeOptions(OptionParser& p, RobotSimNodeOptions* o) {
  // Only what a user sets (issue 27): the scene, mode, frames, rate, seed and orbit, the robot (geometry, footprint,
  // speed limits), the image encoding, the grey stretch of the tracking loss tests, lock-step, ground truth, odometry
  // on/off and the channels. Every other field keeps its default here (the odometry error model too, as the image
  // noise: the simulated robot's sensors, in the README's table); tests and tools set the struct directly.
  p.Add("scene", &o->scene, "scene file (drivers/robot_sim/scenes/*.scene; format in drivers/robot_sim/README.md)");
  p.Add("mode", &o->mode, "orbit (scripted circle around the target) or command (follow ROBOT_COMMAND)");
  p.Add("frames", &o->frames, "frames to publish (command mode: 0 = until stopped)");
  p.Add("rate", &o->rate_hz, "Hz, frame rate: utime = llround(i * 1e6 / rate)");
  p.Add("realtime", &o->realtime, "publish at the rate in wall time (false: as fast as possible)");
  p.Add("seed", &o->seed, "seed (>= 0) of the odometry errors and the image noise");
  p.Add("orbit-radius", &o->orbit_radius_mm, "mm, orbit radius");
  p.Add("orbit-degrees", &o->orbit_degrees, "deg, angle covered over all frames (negative = clockwise)");
  p.Add("robot-file", &o->robot_file,
        "robot.cfg (common/recorded_run.h): the simulated robot's geometry (mast height and offsets, camera offset, "
        "wheel base) and limits (footprint, speed, yaw rate); the pose solver and planner take the same file; none: "
        "mast 400 mm, camera 40 mm forward, footprint 200 mm, 400 mm/s, 90 deg/s");
  p.Add("blank", &o->blank, "FIRST,COUNT: frames rendered as a uniform grey view (tracking loss test; \"\" = none)");
  p.Add("encoding", &o->encoding, "image encoding: rgb8, bgr8, gray8 or jpeg");
  p.Add("jpeg-quality", &o->jpeg_quality, "JPEG quality 1..100 (--encoding jpeg)");
  p.Add("session-id", &o->session_id,
        "the session's id, stamped on every image, calibration and odometry message: 1-16 hex digits (empty = a "
        "random one); processes keep to the first session they hear and refuse the others");
  p.Add("lockstep-channel", &o->lockstep_channel,
        "publish frame i+1 only after a message with seq >= i - lockstep_lag on this channel (empty = off)");
  p.Add("lockstep-timeout-ms", &o->lockstep_timeout_ms, "ms, go on after waiting this long for lockstep (0 = forever)");
  p.Add("ground-truth-dir", &o->ground_truth_dir,
        "write target_surface.ply, scene.txt, poses_gt.txt, robot_gt.txt here (empty = off)");
  p.Add("odometry", &o->publish_odometry,
        "publish ROBOT_ODOMETRY (--odometry=false: images only, to test image-only input; orbit mode only)");
  p.AddChannel(&o->image_channel, "output channel for image_t");
  p.AddChannel(&o->info_channel, "output channel for camera_info_t");
  p.AddChannel(&o->odometry_channel, "output channel for odometry_t");
  p.AddChannel(&o->ground_truth_channel, "output channel for the true camera poses (pose_t)");
  p.AddChannel(&o->command_channel, "input channel of robot_command_t (command mode)");
  p.AddChannel(&o->control_channel, "channel of control_t (END_OF_STREAM out, SHUTDOWN in)");
  p.AddChannel(&o->status_channel, "output channel for process_status_t");
  p.Add("exit-when-finished", &o->exit_when_finished, "exit after END_OF_STREAM");
}

RobotSimOptions ToRobotSimOptions(const RobotSimNodeOptions& o, const RobotDescription* robot_file) {
  RobotSimOptions s;
  s.mode = o.mode;
  s.frames = o.frames;
  s.rate_hz = o.rate_hz;
  s.orbit_radius_mm = o.orbit_radius_mm;
  double values[3] = {0, 0, 0};
  s.orbit_center_auto = o.orbit_center.empty();
  if (!s.orbit_center_auto && ParseList(o.orbit_center, 2, values)) s.orbit_center_mm = {values[0], values[1]};
  s.orbit_degrees = o.orbit_degrees;
  s.orbit_start_deg = o.orbit_start_deg;
  s.look_at_auto = o.look_at.empty();
  if (!s.look_at_auto && ParseList(o.look_at, 3, values)) s.look_at_mm = {values[0], values[1], values[2]};
  s.geometry.mast_height_mm = o.mast_height_mm;
  s.geometry.mast_offset_x_mm = o.mast_offset_x_mm;
  s.geometry.mast_offset_y_mm = o.mast_offset_y_mm;
  s.geometry.camera_offset_mm = Eigen::Vector3d(o.camera_offset_x_mm, 0, 0);
  s.geometry.wheel_base_mm = o.wheel_base_mm;
  const bool from_file = robot_file != nullptr;
  if (from_file) s.geometry = robot_file->geometry;
  s.errors.scale_error = o.odometry_scale_error;
  s.errors.yaw_scale_error = o.odometry_yaw_scale_error;
  s.errors.heading_drift_rad_per_mm = o.heading_drift_deg_per_m * kDeg / 1000.0;
  s.errors.distance_noise = o.distance_noise;
  s.errors.heading_noise_rad_per_sqrt_m = o.heading_noise_deg_per_sqrt_m * kDeg;
  s.errors.pan_bias_rad = o.pan_bias_deg * kDeg;
  s.errors.tilt_bias_rad = o.tilt_bias_deg * kDeg;
  s.errors.head_noise_rad = o.head_noise_deg * kDeg;
  s.errors.sync_offset_us = std::isfinite(o.sync_offset_ms) ? std::llround(o.sync_offset_ms * 1000.0) : 0;
  s.odometry_origin = o.odometry_origin;
  s.seed = static_cast<uint64_t>(o.seed);
  s.max_speed_mm_s = from_file ? robot_file->max_speed_mm_s : o.max_speed_mm_s;
  s.max_omega_rad_s = (from_file ? robot_file->max_omega_deg_s : o.max_omega_deg_s) * kDeg;
  s.max_head_rate_rad_s = o.max_head_rate_deg_s * kDeg;
  s.command_timeout_us = static_cast<int64_t>(o.command_timeout_ms) * 1000;
  s.footprint_radius_mm = from_file ? robot_file->footprint_radius_mm : o.footprint_radius_mm;
  return s;
}

PinholeCamera ToCamera(const RobotSimNodeOptions& o) {
  PinholeCamera c;
  c.name = o.camera_name;
  c.width = o.width;
  c.height = o.height;
  c.fx = o.fx;
  c.fy = o.fy;
  c.cx = o.cx;
  c.cy = o.cy;
  return c;
}

bool ValidateRobotSimNodeOptions(const RobotSimNodeOptions& o, std::string* why, RobotSimOptions* sim_options,
                                 RobotDescription* robot_out) {
  auto fail = [why](const std::string& text) {
    if (why) *why = text;
    return false;
  };
  int8_t encoding = 0;
  double values[3];
  if (o.scene.empty()) return fail("--scene is required");
  int64_t session_id = 0;  // "" draws one: always valid
  if (std::string session_why; !SessionIdFromText(o.session_id, &session_id, &session_why))
    return fail("--session-id: " + session_why);
  if (!o.orbit_center.empty() && !ParseList(o.orbit_center, 2, values)) return fail("orbit_center must be x,y");
  if (!o.look_at.empty() && !ParseList(o.look_at, 3, values)) return fail("look_at must be x,y,z");
  if (o.seed < 0) return fail("--seed must be >= 0");
  RobotDescription robot;  // read once: the simulator runs with what was validated
  if (!o.robot_file.empty()) {
    std::string robot_why;
    if (!ReadRobotFile(o.robot_file, &robot, &robot_why)) return fail("--robot-file: " + robot_why);
  }
  const RobotSimOptions sim = ToRobotSimOptions(o, o.robot_file.empty() ? nullptr : &robot);
  if (!std::isfinite(o.sync_offset_ms) || std::abs(o.sync_offset_ms) > 1e6)
    return fail("sync_offset_ms out of range");
  if (!std::isfinite(o.max_omega_deg_s) || !std::isfinite(o.max_head_rate_deg_s))
    return fail("rate limits must be finite");
  std::string sim_why;
  if (!ValidateRobotSimOptions(sim, &sim_why)) return fail(sim_why);
  std::string camera_why;
  if (!ToCamera(o).IsValid(&camera_why)) return fail("camera: " + camera_why);
  if (o.width > 8192 || o.height > 8192) return fail("width/height must be <= 8192");
  if (!std::isfinite(o.noise_sigma) || o.noise_sigma < 0 || o.noise_sigma > 100)
    return fail("noise_sigma must be in [0, 100]");
  int64_t blank_first = 0, blank_count = 0;
  if (!ParseBlank(o.blank, &blank_first, &blank_count))
    return fail("--blank must be FIRST,COUNT: two whole numbers >= 0, e.g. 80,20 (got '" + o.blank + "')");
  if (!EncodingFromName(o.encoding, &encoding)) return fail("--encoding must be rgb8, bgr8, gray8 or jpeg");
  if (o.jpeg_quality < 1 || o.jpeg_quality > 100) return fail("--jpeg-quality must be in 1..100");
  if (o.lockstep_lag < 0) return fail("lockstep_lag must be >= 0");
  if (o.lockstep_timeout_ms < 0) return fail("--lockstep-timeout-ms must be >= 0");
  if (o.command_timeout_ms < 0) return fail("command_timeout_ms must be >= 0");
  if (!std::isfinite(o.surface_density_per_mm2) || o.surface_density_per_mm2 <= 0 || o.surface_density_per_mm2 > 100)
    return fail("surface_density_per_mm2 must be in (0, 100]");
  if (o.camera_name.empty()) return fail("camera_name must not be empty");
  if (!o.publish_odometry && o.mode == "command")
    return fail("--odometry=false needs --mode orbit: in command mode the planner steers by the odometry");
  if (o.image_channel.empty() || o.info_channel.empty() || o.odometry_channel.empty() ||
      o.ground_truth_channel.empty() || o.command_channel.empty() || o.control_channel.empty() ||
      o.status_channel.empty())
    return fail("channel names must not be empty");
  if (sim_options) *sim_options = sim;
  if (robot_out) *robot_out = robot;  // geometry, speeds and footprint: the writer takes sim's
  return true;
}

RobotSimNode::RobotSimNode(Bus& bus, const RobotSimNodeOptions& options)
    : bus_(bus), options_(options), status_(&bus, kProcessName, options.status_channel) {
  std::string why;
  if (!ValidateRobotSimNodeOptions(options_, &why, &sim_options_, &robot_description_))
    throw std::invalid_argument(why);
  EncodingFromName(options_.encoding, &encoding_);
  ParseBlank(options_.blank, &blank_first_, &blank_count_);
  camera_ = ToCamera(options_);
  scene_ = std::make_unique<Scene>(LoadScene(options_.scene));
  RenderOptions render_options;
  render_options.noise_sigma = options_.noise_sigma;
  render_options.noise_seed = static_cast<uint64_t>(options_.seed);
  render_options.trilinear = options_.trilinear;
  renderer_ = std::make_unique<Renderer>(*scene_, render_options);
  sim_ = std::make_unique<RobotSimulator>(*scene_, sim_options_);
  SessionIdFromText(options_.session_id, &session_id_, &why);  // validated above; "" draws one
  status_.SetSession(session_id_);
  LogInfo("scene " + options_.scene + ": " + std::to_string(scene_->objects.size()) + " objects, target '" +
          scene_->target().name + "'; session " + SessionIdText(session_id_));
  {
    const RobotState& start = sim_->start_state();
    int object = -1;
    const double clearance = sim_->footprint().Clearance(Eigen::Vector2d(start.x_mm, start.y_mm), &object);
    if (clearance < 0)
      LogWarning("the robot starts overlapping '" + scene_->objects.at(static_cast<size_t>(object)).name + "' by " +
                 std::to_string(-clearance) + " mm (footprint radius " +
                 std::to_string(sim_options_.footprint_radius_mm) + " mm)");
  }

  if (!options_.ground_truth_dir.empty()) WriteGroundTruthFiles();
  SubscribeInputs();
  status_.SetState(process_status_t::STATE_STARTING, options_.scene);
  status_.SetValue("frames_published", 0);
  status_.SetValue("collisions", 0);
  status_.SetValue("blocked_frames", 0);
}

void RobotSimNode::WriteGroundTruthFiles() {
  const std::string& dir = options_.ground_truth_dir;
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  const auto samples = SampleSurface(scene_->target(), options_.surface_density_per_mm2,
                                     MixSeed(static_cast<uint64_t>(options_.seed), 0x9f));
  std::vector<Eigen::Vector3f> points, normals;
  for (const auto& s : samples) {
    points.push_back(s.position);
    normals.push_back(s.normal);
  }
  if (!WritePly(dir + "/target_surface.ply", points, normals, {}))
    throw std::runtime_error("cannot write " + dir + "/target_surface.ply");
  // The surface as rendered (the tessellation, within 0.05 mm of a curved primitive): exact surface distances.
  const TriangleMesh& target_mesh = scene_->target().mesh;
  if (!WritePly(dir + "/target_mesh.ply", target_mesh.positions, {}, target_mesh.triangles))
    throw std::runtime_error("cannot write " + dir + "/target_mesh.ply");
  std::ofstream scene_txt(dir + "/scene.txt");
  scene_txt << scene_->Describe();
  scene_txt << "# robot_sim: seed=" << options_.seed << " mode=" << options_.mode << " frames=" << options_.frames
            << " rate=" << options_.rate_hz << " orbit_radius=" << options_.orbit_radius_mm
            << " orbit_center=" << sim_->orbit_center().x() << "," << sim_->orbit_center().y()
            << " orbit_degrees=" << options_.orbit_degrees << " orbit_start_deg=" << options_.orbit_start_deg
            << " look_at=" << sim_->look_at().x() << "," << sim_->look_at().y() << "," << sim_->look_at().z()
            << " footprint_radius=" << sim_options_.footprint_radius_mm << " start=" << sim_->start_state().x_mm << ","
            << sim_->start_state().y_mm << "," << sim_->start_state().theta_rad * 180 / 3.14159265358979323846
            << "\n# camera: " << camera_.width << "x" << camera_.height << " fx=" << camera_.fx << " fy=" << camera_.fy
            << " cx=" << camera_.cx << " cy=" << camera_.cy << " noise_sigma=" << options_.noise_sigma
            << "\n# robot: mast_height=" << sim_options_.geometry.mast_height_mm
            << " camera_offset_x=" << sim_options_.geometry.camera_offset_mm.x()
            << "\n# odometry errors: scale=" << options_.odometry_scale_error
            << " yaw_scale=" << options_.odometry_yaw_scale_error
            << " heading_drift_deg_per_m=" << options_.heading_drift_deg_per_m
            << " distance_noise=" << options_.distance_noise
            << " heading_noise_deg_per_sqrt_m=" << options_.heading_noise_deg_per_sqrt_m
            << " pan_bias_deg=" << options_.pan_bias_deg << " tilt_bias_deg=" << options_.tilt_bias_deg
            << " head_noise_deg=" << options_.head_noise_deg << " sync_offset_ms=" << options_.sync_offset_ms
            << " odometry_origin=" << options_.odometry_origin << "\n";
  if (!scene_txt) throw std::runtime_error("cannot write " + dir + "/scene.txt");
  // The robot's description, as a real robot's owner writes it (objscan_export --robot-file): the simulated robot
  // reports its head angles in objscan's convention; the head's limits are --robot-file's when given.
  RobotDescription robot = robot_description_;
  robot.pan_sign = robot.tilt_sign = 1;
  robot.pan_zero_rad = robot.tilt_zero_rad = 0;
  robot.geometry = sim_->options().geometry;
  robot.footprint_radius_mm = sim_->options().footprint_radius_mm;
  robot.max_speed_mm_s = sim_->options().max_speed_mm_s;
  robot.max_omega_deg_s = sim_->options().max_omega_rad_s / kDeg;
  std::string robot_error;
  if (!WriteRobotFile(dir + "/" + kRobotFileName, robot, &robot_error)) throw std::runtime_error(robot_error);
  poses_gt_.open(dir + "/poses_gt.txt");
  robot_gt_.open(dir + "/robot_gt.txt");
  if (!poses_gt_ || !robot_gt_) throw std::runtime_error("cannot write poses_gt.txt / robot_gt.txt in " + dir);
  poses_gt_ << "# robot_sim true camera poses, TUM format: t tx ty tz qx qy qz qw; t = utime / 1e6 s, "
               "camera-to-world (world_from_camera), positions in mm (not metres)\n";
  robot_gt_ << "# robot_sim true robot state per frame: t seq x_mm y_mm theta_rad pan_rad tilt_rad v_mm_s "
               "omega_rad_s (world frame, t = image utime / 1e6 s)\n";
  poses_gt_ << std::setprecision(10);
  robot_gt_ << std::setprecision(10);
  LogInfo("ground truth in " + dir + " (" + std::to_string(points.size()) + " surface points)");
}

void RobotSimNode::SubscribeInputs() {
  if (options_.mode == "command") {
    bus_.SubscribeMessage<robot_command_t>(
        options_.command_channel,
        [this](const robot_command_t& msg, const RawMessage&) {
          status_.CountIn();
          status_.ObserveSeq("command", msg.seq);
          const bool finite = std::isfinite(msg.v_mm_s) && std::isfinite(msg.omega_rad_s) &&
                              std::isfinite(msg.goal_x_mm) && std::isfinite(msg.goal_y_mm) &&
                              std::isfinite(msg.goal_theta_rad) && std::isfinite(msg.pan_rad) &&
                              std::isfinite(msg.tilt_rad);
          if (!finite) {
            status_.Reject("command: non-finite value", "seq " + std::to_string(msg.seq));
            return;
          }
          if (msg.mode < robot_command_t::MODE_STOP || msg.mode > robot_command_t::MODE_HEAD_ONLY) {
            status_.Reject("command: unknown mode", std::to_string(msg.mode));
            return;
          }
          SimCommand command;
          command.mode = static_cast<SimCommand::Mode>(msg.mode);
          command.v_mm_s = msg.v_mm_s;
          command.omega_rad_s = msg.omega_rad_s;
          command.goal_x_mm = msg.goal_x_mm;
          command.goal_y_mm = msg.goal_y_mm;
          command.goal_theta_rad = msg.goal_theta_rad;
          command.has_pan_tilt = msg.has_pan_tilt || msg.mode == robot_command_t::MODE_HEAD_ONLY;
          command.pan_rad = msg.pan_rad;
          command.tilt_rad = msg.tilt_rad;
          sim_->SetCommand(command, last_utime_);
          ++commands_;
        },
        [this](const RawMessage& raw) {
          status_.CountIn();
          status_.Reject("command: malformed", raw.channel);
        });
  }
  bus_.SubscribeMessage<control_t>(
      options_.control_channel,
      [this](const control_t& msg, const RawMessage&) {
        if (msg.command != control_t::COMMAND_SHUTDOWN) return;
        if (msg.target != "*" && msg.target != kProcessName) return;
        status_.CountIn();
        if (!status_.AcceptSession(msg.session_id, "control")) return;  // another session's planner
        if (!stop_requested_) LogInfo("shutdown requested by " + msg.sender);
        stop_requested_ = true;
      },
      [this](const RawMessage& raw) {
        status_.CountIn();
        status_.Reject("control: malformed", raw.channel);
      });
  if (!options_.lockstep_channel.empty()) {
    bus_.Subscribe(options_.lockstep_channel, [this](const RawMessage& raw) {
      int64_t seq = 0;
      if (!RawMessageSeq(raw.data, raw.size, &seq)) {
        status_.Reject("lockstep: message too short", raw.channel);
        return;
      }
      if (seq > lockstep_max_seq_) lockstep_max_seq_ = seq;
    });
  }
}

RobotSimNode::~RobotSimNode() = default;

template <class Msg>
void RobotSimNode::Publish(const std::string& channel, Msg msg) {
  StampSession(&msg, session_id_);
  if (bus_.PublishMessage(channel, msg)) {
    status_.CountOut();
  } else if (publish_failures_++ == 0) {
    LogError("publishing on " + channel + " failed (further failures are only counted)");
  }
}

bool RobotSimNode::LockstepReady(int64_t wall_utime) {
  if (options_.lockstep_channel.empty() || frames_published_ == 0) return true;
  const int64_t needed = frames_published_ - 1 - options_.lockstep_lag;
  if (needed < 0 || lockstep_max_seq_ >= needed || lockstep_released_ >= needed) {
    lockstep_waiting_for_ = -1;
    return true;
  }
  if (lockstep_waiting_for_ != needed) {
    lockstep_waiting_for_ = needed;
    lockstep_wait_start_ = wall_utime;
  }
  if (options_.lockstep_timeout_ms > 0 &&
      wall_utime - lockstep_wait_start_ >= static_cast<int64_t>(options_.lockstep_timeout_ms) * 1000) {
    ++lockstep_timeouts_;
    if (!lockstep_warned_) {
      LogWarning("no seq >= " + std::to_string(needed) + " on " + options_.lockstep_channel + " within " +
                 std::to_string(options_.lockstep_timeout_ms) + " ms; going on (further timeouts are only counted)");
      lockstep_warned_ = true;
    }
    lockstep_released_ = needed;
    lockstep_waiting_for_ = -1;
    return true;
  }
  return false;
}

void RobotSimNode::PublishFrame() {
  const SimFrame frame = sim_->Step();
  const int64_t render_start = MonotonicMicros();
  renderer_->Render(camera_, frame.world_from_camera, &render_, static_cast<uint64_t>(frame.seq));
  render_ms_ = (MonotonicMicros() - render_start) / 1000.0;
  status_.RecordLatencyMs(render_ms_);

  Publish(options_.info_channel, CameraToMessage(camera_, frame.utime));
  if (options_.publish_odometry) Publish(options_.odometry_channel, OdometryToMessage(frame.odometry));
  if (options_.publish_ground_truth) {
    CameraPoseEstimate pose;
    pose.utime = frame.utime;
    pose.seq = frame.seq;
    pose.world_from_camera = frame.world_from_camera;
    pose.status = PoseStatus::kGroundTruth;
    pose.scale_source = ScaleSource::kTrue;
    Publish(options_.ground_truth_channel, PoseToMessage(pose, "world", "camera"));
  }
  ImageFrame image;
  image.utime = frame.utime;
  image.seq = frame.seq;
  image.camera_name = camera_.name;
  image.image = render_.rgb;
  if (frame.seq >= blank_first_ && frame.seq < blank_first_ + blank_count_)
    image.image = cv::Mat(render_.rgb.size(), render_.rgb.type(), cv::Scalar::all(128));
  Publish(options_.image_channel, ImageToMessage(image, encoding_, options_.jpeg_quality));

  if (poses_gt_.is_open()) {
    const Eigen::Quaterniond q(frame.world_from_camera.linear());
    const Eigen::Vector3d t = frame.world_from_camera.translation();
    poses_gt_ << frame.utime / 1e6 << " " << t.x() << " " << t.y() << " " << t.z() << " " << q.x() << " " << q.y()
              << " " << q.z() << " " << q.w() << "\n";
    const RobotState& s = frame.truth;
    robot_gt_ << frame.utime / 1e6 << " " << frame.seq << " " << s.x_mm << " " << s.y_mm << " " << s.theta_rad << " "
              << s.pan_rad << " " << s.tilt_rad << " " << s.v_mm_s << " " << s.omega_rad_s << "\n";
  }
  if (frame.new_collision) {
    const std::string object = frame.collision_object >= 0
                                   ? scene_->objects.at(static_cast<size_t>(frame.collision_object)).name
                                   : std::string("?");
    LogWarning("collision " + std::to_string(sim_->collisions()) + " at frame " + std::to_string(frame.seq) +
               ": the base touches '" + object + "'" +
               (options_.mode == "command" ? " (stopped)" : " (orbit: motion unchanged)"));
  }
  truth_history_.push_back(frame.truth);
  last_utime_ = frame.utime;
  ++frames_published_;
  status_.SetLastDataUtime(frame.utime);
  status_.SetValue("frames_published", static_cast<double>(frames_published_));
  status_.SetValue("render_ms", render_ms_);
  status_.SetValue("collisions", static_cast<double>(sim_->collisions()));
  status_.SetValue("blocked_frames", static_cast<double>(sim_->blocked_frames()));
}

void RobotSimNode::WriteOutcome() {
  const std::string path = options_.ground_truth_dir + "/sim_outcome.json";
  const SceneObject& target = scene_->target();
  const OrientedBox box = ObjectBox(target);
  auto vec = [](const Eigen::Vector3d& v) {
    std::ostringstream out;
    out << std::setprecision(10) << "[" << v.x() << ", " << v.y() << ", " << v.z() << "]";
    return out.str();
  };
  std::ofstream file(path);
  file << std::setprecision(10) << "{\n"
       << "  \"mode\": " << JsonQuoted(options_.mode) << ",\n"
       << "  \"frames\": " << frames_published_ << ",\n"
       << "  \"collisions\": " << sim_->collisions() << ",\n"
       << "  \"blocked_frames\": " << sim_->blocked_frames() << ",\n"
       << "  \"path_length_mm\": " << sim_->path_length_mm() << ",\n"
       << "  \"footprint_radius_mm\": " << sim_options_.footprint_radius_mm << ",\n"
       << "  \"target\": {\n"
       << "    \"name\": " << JsonQuoted(target.name) << ",\n"
       << "    \"shape\": " << JsonQuoted(ShapeName(target.type)) << ",\n"
       << "    \"center_mm\": " << vec(box.center_mm) << ",\n"
       << "    \"size_mm\": " << vec(box.size_mm) << ",\n"
       << "    \"yaw_rad\": " << box.yaw_rad << ",\n"
       << "    \"bounds_min_mm\": " << vec(target.bounds.min()) << ",\n"
       << "    \"bounds_max_mm\": " << vec(target.bounds.max()) << "\n"
       << "  }\n"
       << "}\n";
  if (!file) LogError("cannot write " + path);
}

void RobotSimNode::FinishStream() {
  if (end_of_stream_sent_) return;
  control_t msg;
  msg.utime = last_utime_;
  msg.session_id = 0;  // Publish stamps the session
  msg.sender = kProcessName;
  msg.target = "*";
  msg.command = control_t::COMMAND_END_OF_STREAM;
  msg.last_seq = frames_published_ - 1;
  msg.argument = "";
  Publish(options_.control_channel, msg);
  end_of_stream_sent_ = true;
  if (poses_gt_.is_open()) poses_gt_.flush();
  if (robot_gt_.is_open()) robot_gt_.flush();
  if (!options_.ground_truth_dir.empty()) WriteOutcome();
  status_.SetState(process_status_t::STATE_FINISHED, std::to_string(frames_published_) + " frames published");
  std::ostringstream outcome;
  outcome << "end of stream after " << frames_published_ << " frames; " << sim_->collisions() << " collisions, "
          << sim_->blocked_frames() << " blocked frames, true base path " << std::llround(sim_->path_length_mm())
          << " mm";
  LogInfo(outcome.str());
}

void RobotSimNode::Tick(int64_t wall_utime) {
  if (!end_of_stream_sent_) {
    if (!started_) {
      started_ = true;
      start_wall_ = wall_utime;
      status_.SetState(process_status_t::STATE_RUNNING, options_.mode);
    }
    const bool at_end = sim_->Done() || stop_requested_;
    const bool due = !options_.realtime || at_end || wall_utime >= start_wall_ + sim_->UtimeOf(sim_->frames_produced());
    if (due && LockstepReady(wall_utime)) {
      if (at_end)
        FinishStream();
      else
        PublishFrame();
    }
  }
  status_.SetValue("lockstep_timeouts", static_cast<double>(lockstep_timeouts_));
  status_.SetValue("commands", static_cast<double>(commands_));
  status_.PublishIfDue(wall_utime);
}

void RobotSimNode::OnShutdown() {
  if (!end_of_stream_sent_) FinishStream();
  status_.PublishIfDue(WallTimeMicros(), true);
}

}  // namespace objscan
