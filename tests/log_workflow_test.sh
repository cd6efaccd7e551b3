#!/usr/bin/env bash
# The everyday LCM workflow with `objscan log`, in a private multicast namespace: record a session (objscan run), see
# what it holds (log info), keep what the drivers published (log filter --sensors: no old outputs, no old
# COMMAND_FINISHED), check that cut + merge give the same log back, then play it with lcm-logplayer in real time into
# live tracker, pose solver and dense modeler processes. Their trajectory and model must match `objscan replay` of the
# session log (in one process, deterministic) within tolerance, against the simulator's truth.
set -euo pipefail
BIN="$1"; SRC="$2"
source "$SRC/tests/netns_lib.sh"
netns_require
NS=$(netns_name logplay); netns_create "$NS"
WORK=$(mktemp -d); trap 'netns_cleanup; rm -rf "$WORK"' EXIT
export OBJSCAN_BUILD_DIR="$(dirname "$BIN")"
LOGTOOL="$BIN/objscan_logtool"
FRAMES=90

# 1. A recorded session: every process's output is in session.lcmlog next to the simulator's messages.
in_ns "$NS" "$SRC/objscan" run --sim --orbit --scene sphere --frames $FRAMES --out "$WORK/rec" \
  --lcm-url "udpm://239.255.76.67:7671?ttl=0&recv_buf_size=4194304" > "$WORK/rec.out" 2>&1 \
  || { tail -n 30 "$WORK/rec.out"; fail "recording the session failed"; }
SESSION="$WORK/rec/session.lcmlog"
"$LOGTOOL" info "$SESSION" > "$WORK/info.txt" || { cat "$WORK/info.txt"; fail "log info on an intact log exited non-zero"; }
cat "$WORK/info.txt"
count() { awk -v c="$2" '$1 == c {print $2}' "$1"; }
[ "$(count "$WORK/info.txt" CAMERA_IMAGE)" = "$FRAMES" ] || fail "log info: expected $FRAMES images"
[ -n "$(count "$WORK/info.txt" CAMERA_POSE)" ] || fail "log info: the session log has no CAMERA_POSE"

# 2. The drivers' part of it.
SENSORS="$WORK/sensors.lcmlog"
"$LOGTOOL" filter "$SESSION" "$SENSORS" --sensors --drop GROUND_TRUTH_POSE
"$LOGTOOL" info "$SENSORS" > "$WORK/sensors.txt" || { cat "$WORK/sensors.txt"; fail "log info on the filtered log failed"; }
cat "$WORK/sensors.txt"
[ "$(count "$WORK/sensors.txt" CAMERA_IMAGE)" = "$FRAMES" ] || fail "filter lost images"
[ "$(count "$WORK/sensors.txt" OBJSCAN_CONTROL)" = 1 ] || fail "filter --sensors should keep only the end of stream"
for ch in CAMERA_POSE FEATURE_TRACKS LANDMARKS VOXEL_MAP PROCESS_STATUS GROUND_TRUTH_POSE; do
  [ -z "$(count "$WORK/sensors.txt" $ch)" ] || fail "filter kept $ch"
done

# 3. Cut in two and merged again: the same messages, byte for byte.
"$LOGTOOL" cut "$SENSORS" "$WORK/a.lcmlog" --to 1.5 > /dev/null
"$LOGTOOL" cut "$SENSORS" "$WORK/b.lcmlog" --from 1.5 > /dev/null
"$LOGTOOL" merge "$WORK/ab.lcmlog" "$WORK/b.lcmlog" "$WORK/a.lcmlog" > /dev/null
"$LOGTOOL" compare-bytes "$SENSORS" "$WORK/ab.lcmlog" || fail "cut + merge changed the log"
# A damaged log (a logger that died mid-write: the last event cut short) is reported, not silently shortened: exit 1
# and the damage named.
cp "$SENSORS" "$WORK/damaged.lcmlog"
truncate -s -1000 "$WORK/damaged.lcmlog"
rc=0; "$LOGTOOL" filter "$WORK/damaged.lcmlog" "$WORK/d.lcmlog" --keep '*' > /dev/null 2> "$WORK/damaged.err" || rc=$?
[ "$rc" = 1 ] && grep -q "damaged input" "$WORK/damaged.err" || { cat "$WORK/damaged.err"; fail "damage not reported (rc $rc)"; }

# 4. Reference: the session log replayed in one process.
"$BIN/objscan_replay" --log "$SESSION" --out "$WORK/ref" > "$WORK/ref.out" 2>&1 \
  || { tail -n 20 "$WORK/ref.out"; fail "objscan replay failed"; }

# 5. Live: lcm-logplayer plays the drivers' log in real time into the three processes on a fresh bus.
URL="udpm://239.255.76.67:7672?ttl=0&recv_buf_size=4194304"
mkdir -p "$WORK/live"
ip netns exec "$NS" "$BIN/tracker" --lcm-url "$URL" --image-queue-capacity 200 > "$WORK/tracker.out" 2>&1 &
ip netns exec "$NS" "$BIN/pose_solver" --lcm-url "$URL" --output-dir "$WORK/live" > "$WORK/pose.out" 2>&1 &
ip netns exec "$NS" "$BIN/dense_modeler" --lcm-url "$URL" --output-dir "$WORK/live" --image-queue-capacity 200 \
  > "$WORK/dense.out" 2>&1 &
DENSE=$!
sleep 1.5
in_ns "$NS" lcm-logplayer -s 1 --lcm-url="$URL" "$SENSORS" > "$WORK/player.out" 2>&1 || fail "lcm-logplayer failed"
for _ in $(seq 1 1200); do kill -0 $DENSE 2>/dev/null || break; sleep 0.1; done
kill -0 $DENSE 2>/dev/null && { tail -n 20 "$WORK/dense.out"; fail "the live dense modeler did not finish within 120 s"; }
wait $DENSE || { tail -n 20 "$WORK/dense.out"; fail "the live dense modeler failed"; }
for f in trajectory.txt model_mesh.ply; do
  [ -s "$WORK/live/$f" ] || { tail -n 20 "$WORK/pose.out" "$WORK/dense.out"; fail "live run wrote no $f"; }
done

# 6. Live against replay, both against the simulator's truth.
GT="$WORK/rec/ground_truth"
figure() { awk -v k="$2" '$1 == k {print $2}' <<< "$1"; }
for run in ref live; do
  t=$("$BIN/objscan_evaluate" trajectory "$WORK/$run/trajectory.txt" "$GT/poses_gt.txt")
  s=$("$BIN/objscan_evaluate" surface "$WORK/$run/model_mesh.ply" "$GT/target_surface.ply" --truth-mesh "$GT/target_mesh.ply" \
        --align "$WORK/$run/trajectory.txt" "$GT/poses_gt.txt" --visible-from "$GT/poses_gt.txt")
  declare "ate_$run=$(figure "$t" ate_rmse)" "reg_$run=$(figure "$t" registered_fraction)"
  declare "p90_$run=$(figure "$s" accuracy_p90)" "comp_$run=$(figure "$s" completeness)"
done
printf '  %-8s %12s %12s %12s %14s\n' run "ATE mm" registered "mesh p90 mm" completeness
printf '  %-8s %12s %12s %12s %14s\n' replay "$ate_ref" "$reg_ref" "$p90_ref" "$comp_ref" live "$ate_live" "$reg_live" "$p90_live" "$comp_live"
awk -v a="$ate_live" -v ar="$ate_ref" -v r="$reg_live" -v p="$p90_live" -v pr="$p90_ref" -v c="$comp_live" -v cr="$comp_ref" '
  BEGIN { ok = r >= 0.99 && a <= 2 * ar + 0.1 && p <= 1.5 * pr + 0.1 && c >= cr - 0.03; exit !ok }' \
  || fail "the live processes fed by lcm-logplayer differ from objscan replay beyond tolerance"
echo "PASS: session log -> filter --sensors -> lcm-logplayer -> live processes: the same model as objscan replay"
