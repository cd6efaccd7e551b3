#!/usr/bin/env bash
# A recorded robot run kept as a folder (issue 25): the simulator's orbit with odometry, on a robot whose mast is not
# the default height (450 mm), exported with objscan_export --robot-file (images/, calib.yaml, timestamps.txt,
# odometry.txt, robot.cfg), then run as `objscan run --dataset DIR` with no flags on a live bus. It must replay with
# odometry exactly like the live robot: the camera driver publishes every reading at its recorded time, the pose
# solver takes the geometry from robot.cfg, the lengths are metric (a robot.cfg ignored would give the default 400 mm
# mast and a scale 0.889 off), and the poses match objscan_replay of the simulator's own log.
# The same as a video folder (objscan_export --video) replays with its odometry too, within JPEG's cost.
# A folder with odometry.txt but no robot.cfg is refused with a message that says what to add.
set -euo pipefail
BIN="$1"; SRC="$2"
source "$SRC/tests/netns_lib.sh"
netns_require
NS=$(netns_name recorded); netns_create "$NS"
WORK=$(mktemp -d); trap 'netns_cleanup; rm -rf "$WORK"' EXIT
export OBJSCAN_BUILD_DIR="$(dirname "$BIN")"
URL="udpm://239.255.76.67:7671?ttl=0&recv_buf_size=4194304"
FAILED=0
source "$SRC/tests/accuracy_lib.sh"

d="$WORK/sphere"; mkdir -p "$d"
printf 'mast_height_mm = 450\n' > "$d/robot450.cfg"
render_orbit sphere "$d" --robot-file "$d/robot450.cfg"
[ -s "$d/gt/robot.cfg" ] || fail "robot_sim wrote no robot.cfg"
"$BIN/objscan_export" --log "$d/sim.lcmlog" --out "$d/folder" --robot-file "$d/gt/robot.cfg" > "$d/export.out" 2>&1 \
  || { cat "$d/export.out"; fail "objscan_export"; }
for f in timestamps.txt odometry.txt robot.cfg calib.yaml; do [ -s "$d/folder/$f" ] || fail "export wrote no $f"; done
grep -q "^odometry_written 200$" "$d/export.out" || { cat "$d/export.out"; fail "export: not 200 odometry readings"; }

# The reference: the simulator's own log replayed with the same robot.
"$BIN/objscan_replay" --log "$d/sim.lcmlog" --out "$d/replay" --pose-solver-args "--robot-file $d/gt/robot.cfg" \
  > "$d/replay.out" 2>&1 || { tail -30 "$d/replay.out"; fail "objscan_replay"; }

in_ns "$NS" "$SRC/objscan" run --dataset "$d/folder" --out "$d/run" --lcm-url "$URL" > "$d/run.out" 2>&1 \
  || { tail -n 30 "$d/run.out"; fail "objscan run --dataset (recorded run) failed"; }
grep -q "recorded robot run" "$d/run.out" || { cat "$d/run.out"; fail "the run did not say it replays a recorded run"; }
grep -q '"scale_metric": true' "$d/run/summary.json" || fail "recorded run: lengths not metric"
grep -q '"odometry_published": 200' "$d/run/summary.json" || fail "camera: not 200 odometry readings published"
grep -q '"frames_without_odometry": 0' "$d/run/summary.json" || fail "camera: frames without odometry"

GT="$d/gt/poses_gt.txt"
echo "recorded run as a folder (live bus) against the simulator's log replayed:"
for f in trajectory trajectory_online; do
  "$BIN/objscan_evaluate" trajectory "$d/run/$f.txt" "$GT" > "$d/run-$f.txt" || fail "evaluate $f"
  "$BIN/objscan_evaluate" trajectory "$d/replay/$f.txt" "$GT" > "$d/replay-$f.txt" || fail "evaluate replay $f"
  live=$(value ate_rmse "$d/run-$f.txt"); ref=$(value ate_rmse "$d/replay-$f.txt")
  info "$f ATE RMSE (mm), simulator's log replayed" "$ref"
  check "$f ATE RMSE (mm), folder" "$live" "<=" "$(awk -v r="$ref" 'BEGIN{print 1.2 * r + 0.02}')"
  check "$f scale error (metric, no alignment scale)" \
    "$(awk -v s="$(value scale "$d/run-$f.txt")" 'BEGIN{e = s - 1; print (e < 0 ? -e : e)}')" "<=" 0.005
  check "$f registered fraction" "$(value registered_fraction "$d/run-$f.txt")" ">=" 0.99
done

# The same run kept as a video folder (video.avi, Motion-JPEG, frame-numbered timestamps.txt): replays with its
# odometry at the recorded times too; JPEG costs some accuracy.
"$BIN/objscan_export" --log "$d/sim.lcmlog" --out "$d/video" --video --robot-file "$d/gt/robot.cfg" \
  > "$d/export-video.out" 2>&1 || { cat "$d/export-video.out"; fail "objscan_export --video"; }
[ -s "$d/video/video.avi" ] && [ ! -e "$d/video/images" ] || fail "export --video wrote no video.avi, or images/"
in_ns "$NS" "$SRC/objscan" run --dataset "$d/video" --out "$d/run-video" --lcm-url "$URL" > "$d/run-video.out" 2>&1 \
  || { tail -n 30 "$d/run-video.out"; fail "objscan run --dataset (recorded run as video) failed"; }
grep -q "recorded robot run" "$d/run-video.out" || { cat "$d/run-video.out"; fail "video: not run as a recorded run"; }
grep -q '"odometry_published": 200' "$d/run-video/summary.json" || fail "video: not 200 odometry readings published"
grep -q '"frames_without_odometry": 0' "$d/run-video/summary.json" || fail "video: frames without odometry"
echo "recorded run as a video folder:"
for f in trajectory trajectory_online; do
  "$BIN/objscan_evaluate" trajectory "$d/run-video/$f.txt" "$GT" > "$d/video-$f.txt" || fail "evaluate video $f"
  ref=$(value ate_rmse "$d/replay-$f.txt")
  check "$f ATE RMSE (mm), video folder" "$(value ate_rmse "$d/video-$f.txt")" "<=" \
    "$(awk -v r="$ref" 'BEGIN{print 3 * r + 0.1}')"
  check "$f scale error, video folder" \
    "$(awk -v s="$(value scale "$d/video-$f.txt")" 'BEGIN{e = s - 1; print (e < 0 ? -e : e)}')" "<=" 0.005
  check "$f registered fraction, video folder" "$(value registered_fraction "$d/video-$f.txt")" ">=" 0.99
done

# odometry.txt without robot.cfg: refused, and the message says what to add.
rm "$d/folder/robot.cfg"
if in_ns "$NS" "$SRC/objscan" run --dataset "$d/folder" --out "$d/run2" --lcm-url "$URL" > "$d/run2.out" 2>&1; then
  fail "a recorded run without robot.cfg was accepted"
fi
grep -q "needs .*robot.cfg" "$d/run2.out" || { cat "$d/run2.out"; fail "the refusal does not name robot.cfg"; }

[ "$FAILED" = 0 ] || fail "recorded run figures out of bounds"
echo "PASS: a recorded robot run replays from its folder with odometry, metric and as accurate as the live log"
