// Writes an LCM log with one message of every objscan type (channel = type name in capitals, e.g. "POSE_T")
// for the lcm-spy decode test. Usage: objscan_spy_log_writer OUT.lcmlog [--with-garbage]
// --with-garbage appends one event that is no objscan type (the decode check must then fail).
#include <cstdio>
#include <string>

#include "common/bus.h"
#include "objscan/camera_info_t.hpp"
#include "objscan/control_t.hpp"
#include "objscan/feature_tracks_t.hpp"
#include "objscan/image_t.hpp"
#include "objscan/landmarks_t.hpp"
#include "objscan/model_t.hpp"
#include "objscan/odometry_t.hpp"
#include "objscan/pose_t.hpp"
#include "objscan/process_status_t.hpp"
#include "objscan/procman_deputy_t.hpp"
#include "objscan/procman_orders_t.hpp"
#include "objscan/procman_output_t.hpp"
#include "objscan/robot_command_t.hpp"
#include "objscan/target_t.hpp"
#include "objscan/voxel_map_t.hpp"

int main(int argc, char** argv) {
  using namespace objscan;
  const bool garbage = argc == 3 && std::string(argv[2]) == "--with-garbage";
  if ((argc != 2 && !garbage) || argv[1][0] == '-') {  // an option where OUT belongs is an error, not a file name
    std::fprintf(stderr, "usage: %s OUT.lcmlog [--with-garbage]\n", argv[0]);
    return 2;
  }
  try {
    auto bus = MakeLcmBus(std::string("datalog://") + argv[1] + "?exclude=NONE");
    bool ok = true;
    camera_info_t info{};
    info.utime = 1;
    info.camera_name = "cam";
    info.width = 640;
    info.height = 480;
    info.fx = info.fy = 500;
    info.distortion_model = "plumb_bob";
    info.num_distortion = 5;
    info.distortion = {0.1, -0.01, 0, 0, 0};
    ok &= bus->PublishMessage("CAMERA_INFO_T", info);
    control_t control{};
    control.utime = 2;
    control.sender = "robot_sim";
    control.target = "*";
    control.last_seq = 7;
    ok &= bus->PublishMessage("CONTROL_T", control);
    feature_tracks_t tracks{};
    tracks.utime = 3;
    tracks.num_tracks = 2;
    tracks.track_id = {1, 2};
    tracks.u = {1.5f, 2.5f};
    tracks.v = {3.5f, 4.5f};
    tracks.age = {0, 3};
    ok &= bus->PublishMessage("FEATURE_TRACKS_T", tracks);
    image_t image{};
    image.utime = 4;
    image.width = 2;
    image.height = 2;
    image.stride = 2;
    image.encoding = image_t::ENCODING_GRAY8;
    image.size = 4;
    image.data = {1, 2, 3, 4};
    ok &= bus->PublishMessage("IMAGE_T", image);
    landmarks_t landmarks{};
    landmarks.utime = 5;
    landmarks.frame = "world";
    landmarks.num_landmarks = 1;
    landmarks.id = {9};
    landmarks.position_mm = {{1, 2, 3}};
    landmarks.num_observations = {4};
    landmarks.reprojection_error_px = {0.3f};
    landmarks.rgb = {{10, 20, 30}};
    ok &= bus->PublishMessage("LANDMARKS_T", landmarks);
    model_t model{};
    model.utime = 6;
    model.voxels_ply_path = "/tmp/v.ply";
    ok &= bus->PublishMessage("MODEL_T", model);
    odometry_t odometry{};
    odometry.utime = 7;
    odometry.x_mm = 12;
    ok &= bus->PublishMessage("ODOMETRY_T", odometry);
    pose_t pose{};
    pose.utime = 8;
    pose.parent_frame = "world";
    pose.child_frame = "camera";
    pose.orientation[0] = 1;
    ok &= bus->PublishMessage("POSE_T", pose);
    process_status_t status{};
    status.utime = 9;
    status.name = "tracker";
    status.num_rejection_reasons = 1;
    status.rejection_reason = {"image: wrong size"};
    status.rejection_count = {3};
    status.num_values = 1;
    status.value_name = {"live_tracks"};
    status.value = {42};
    ok &= bus->PublishMessage("PROCESS_STATUS_T", status);
    robot_command_t command{};
    command.utime = 10;
    command.mode = robot_command_t::MODE_VELOCITY;
    ok &= bus->PublishMessage("ROBOT_COMMAND_T", command);
    target_t target{};
    target.utime = 11;
    target.frame = "world";
    ok &= bus->PublishMessage("TARGET_T", target);
    voxel_map_t voxels{};
    voxels.utime = 12;
    voxels.frame = "world";
    voxels.voxel_size_mm = 5;
    voxels.num_voxels = 1;
    voxels.ijk = {{1, 2, 3}};
    voxels.votes = {4};
    voxels.rgb = {{5, 6, 7}};
    ok &= bus->PublishMessage("VOXEL_MAP_T", voxels);
    procman_orders_t orders{};
    orders.utime = 13;
    orders.sheriff = "sheriff";
    orders.host = "robot";
    orders.config_hash = "0123456789abcdef";
    orders.num_processes = 1;
    orders.name = {"tracker"};
    orders.run = {1};
    orders.run_id = {1};
    orders.follow_output = {0};
    ok &= bus->PublishMessage("PROCMAN_ORDERS_T", orders);
    procman_deputy_t deputy{};
    deputy.utime = 14;
    deputy.host = "robot";
    deputy.config_hash = "0123456789abcdef";
    deputy.last_refusal = "";
    deputy.num_processes = 1;
    deputy.name = {"tracker"};
    deputy.group = {"robot"};
    deputy.message = {"started run 1"};
    deputy.state = {static_cast<int8_t>(procman_deputy_t::STATE_RUNNING)};
    deputy.desired_run = {1};
    deputy.desired_run_id = {1};
    deputy.run_id = {1};
    deputy.pid = {4242};
    deputy.exit_code = {0};
    deputy.exit_signal = {0};
    deputy.restarts = {0};
    deputy.cpu_percent = {1.5f};
    deputy.rss_kb = {2048};
    deputy.uptime_s = {3.0f};
    ok &= bus->PublishMessage("PROCMAN_DEPUTY_T", deputy);
    procman_output_t output{};
    output.utime = 15;
    output.host = "robot";
    output.name = "tracker";
    output.text = "hello\n";
    ok &= bus->PublishMessage("PROCMAN_OUTPUT_T", output);
    if (garbage) {
      const char junk[] = "0123456789abcdef: not an objscan message";
      ok &= bus->Publish("GARBAGE", junk, sizeof(junk));
    }
    if (!ok) {
      std::fprintf(stderr, "publishing failed\n");
      return 1;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
